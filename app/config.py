"""The one Settings object. Nothing else in the project reads ``os.environ``.

Every value has an embedded default so that a fresh checkout runs with no
configuration at all: a SQLite file under ``./var``, artifacts under ``./var/data``,
no broker (Celery then runs tasks eagerly, in-process) and PoCL on the CPU.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

from pydantic import Field
from pydantic_settings import BaseSettings, SettingsConfigDict


class Settings(BaseSettings):
    model_config = SettingsConfigDict(env_prefix="SRG_", env_file=".env", extra="ignore")

    var_dir: Path = Path("var")
    database_url: str = ""
    artifact_dir: Path | None = None
    broker_url: str = ""
    result_backend: str = ""
    redis_url: str = ""

    # Growth
    batch_size: int = Field(4, description="blend edges expanded per growth epoch")
    prefilter_k: int = Field(100, description="energy pre-filter size for best-target search")
    restart_steps: float = Field(90.0, description="default mean session length L (steps)")
    alpha: float = Field(0.8, description="heuristic player model: keep-control probability")
    crowd_radius: float = Field(0.0, description="crowd model kernel radius r (0: per dynamics)")
    crowd_eps: float = Field(1e-3, description="crowd model prior weight epsilon")
    high_error_threshold: float = Field(0.0, description="0: per dynamics default")

    # OpenCL
    opencl_device: str = Field("", description="substring of the OpenCL device name; '' = PoCL CPU")

    # Celery
    task_soft_time_limit: int = 600
    task_time_limit: int = 900
    task_max_retries: int = 3

    # API
    admin_token: str = "change-me"
    max_trace_bytes: int = 1_000_000
    uploads_per_minute: int = 60

    @property
    def resolved_database_url(self) -> str:
        if self.database_url:
            return self.database_url
        return f"sqlite:///{(self.var_dir / 'srg.sqlite3').resolve()}"

    @property
    def resolved_artifact_dir(self) -> Path:
        return self.artifact_dir if self.artifact_dir is not None else self.var_dir / "data"

    @property
    def eager(self) -> bool:
        """No broker configured means Celery runs every task in-process."""
        return not self.broker_url


@lru_cache(maxsize=1)
def get_settings() -> Settings:
    return Settings()
