"""The settings: one ``Settings`` value, in groups. Nothing else in ``app`` reads
``os.environ``.

Each group (growth, render, runtime, api) reads its own fields, each from one flat
``SRG_<FIELD>`` variable (docs/design.md, "Settings"). Every value has an embedded
default so that a fresh checkout runs with no configuration at all: a SQLite file under
``./var``, artifacts under ``./var/data``, no broker (Celery then runs tasks eagerly,
in-process) and PoCL on the CPU.

Every value is checked where it is read, so a command or a server refuses a bad one in
one line before it starts: numbers have both bounds, choices their values, URLs a scheme.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

from pydantic import (
    AliasChoices,
    Field,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)
from pydantic_core import ErrorDetails, InitErrorDetails
from pydantic_settings import BaseSettings, SettingsConfigDict

from app.config_types import (
    DAY,
    GIB,
    MIB_PER_TIB,
    BrokerURL,
    DatabaseURL,
    DirectoryPath,
    PostgresURL,
    RateLimits,
    RedisURL,
    WebOrigins,
)
from app.core.errors import InvalidInput
from app.core.players.kinds import PlayerModelKind

_SOURCES = SettingsConfigDict(
    env_prefix="SRG_",
    env_file=".env",
    extra="ignore",
    allow_inf_nan=False,
    populate_by_name=True,
)


class GrowthSettings(BaseSettings):
    """How a graph grows: what an epoch expands and how STATERANK and the crowd model
    choose it (docs/runtime.md, docs/player-models.md)."""

    model_config = _SOURCES

    batch_size: int = Field(4, ge=1, le=1_000, description="blend edges expanded per growth epoch")
    prefilter_k: int = Field(
        100, ge=1, le=100_000, description="energy pre-filter size for best-target search"
    )
    restart_steps: float = Field(
        90.0, ge=1.0, le=1e6, description="default mean session length L (steps)"
    )
    max_session_steps: float = Field(
        900.0, ge=2.0, le=1e6, description="ceiling of the session length L STATERANK restarts with"
    )
    alpha: float = Field(
        0.8, ge=0.0, le=1.0, description="heuristic player model: keep-control probability"
    )
    crowd_radius: float = Field(
        0.0, ge=0.0, le=1e6, description="crowd model kernel radius r (0: per dynamics)"
    )
    crowd_eps: float = Field(1e-3, gt=0.0, le=1.0, description="crowd model prior weight epsilon")
    high_error_threshold: float = Field(0.0, ge=0.0, le=1e6, description="0: per dynamics default")
    player_model: PlayerModelKind = Field(
        PlayerModelKind.MIXED_ERROR,
        description="crowd model of new sr-crowd graphs (docs/player-models.md)",
    )
    reuse_simulations: bool = Field(
        True,
        description="a liquid clip already simulated from the same state and control is "
        "reused, not simulated again (docs/runtime.md)",
    )


class RenderSettings(BaseSettings):
    """When and with which Mitsuba variant clips become animations (docs/render.md)."""

    model_config = _SOURCES

    growth_renders: bool = Field(
        True, description="render clip and blend animations while growing (else at publish)"
    )
    dedup_error_fraction: float = Field(
        0.1,
        ge=0.0,
        le=1.0,
        description="a clip shows a nearly identical rendered clip's animation when the "
        "substitution error is at most this fraction of the high-error threshold; 0: never",
    )
    render_variant: Literal["auto", "scalar_rgb", "llvm_ad_rgb"] = Field(
        "auto",
        description="Mitsuba variant: auto (llvm_ad_rgb when a working libLLVM is found, "
        "else scalar_rgb)",
    )
    llvm_path: str = Field(
        "",
        validation_alias=AliasChoices("SRG_LLVM_PATH", "DRJIT_LIBLLVM_PATH"),
        description="libLLVM for Mitsuba's LLVM variant ('': look in the system's lib dirs)",
    )


class RuntimeSettings(BaseSettings):
    """How the workers, beat and the caches run the work (docs/runtime.md)."""

    model_config = _SOURCES

    opencl_device: str = Field("", description="substring of the OpenCL device name; '' = PoCL CPU")
    simulate_batch: int = Field(1, ge=1, le=64, description="clips one srg.simulate runs together")
    task_time_limit: int = Field(900, ge=1, le=7 * DAY, description="seconds a task runs at most")
    task_soft_time_limit: int = Field(
        600,
        ge=1,
        le=7 * DAY,
        description="seconds after which a task is asked to stop (below task_time_limit)",
    )
    task_max_retries: int = Field(
        3,
        ge=0,
        le=100,
        description="retries of a task that waits, and redeliveries of a lost one, at most",
    )
    beat_interval: float = Field(
        30.0, gt=0.0, le=DAY, description="seconds between beat's growth ticks"
    )
    publish_every: int = Field(
        600,
        ge=0,
        le=1_000_000_000,
        description="simulated frames a growing graph grows between the publications beat "
        "makes of it (one at once when it has none); 0: beat never publishes",
    )
    epoch_check_interval: float = Field(
        10.0,
        gt=0,
        le=3600,
        description="seconds between the workers' looks at every running epoch's missing "
        "work; work that no live worker or queue holds on two looks in a row is re-sent",
    )
    epoch_resend_after: float = Field(
        1800.0,
        gt=0,
        le=7 * DAY,
        description="seconds without progress after which a running epoch is re-sent, "
        "alive or not (the backstop)",
    )
    artifact_gc_interval: float = Field(
        float(DAY), ge=0, le=365 * DAY, description="seconds between beat's `srg gc` runs; 0: never"
    )
    artifact_gc_grace: float = Field(
        3600.0,
        ge=0,
        le=365 * DAY,
        description="orphaned artifacts younger than this (s) are kept by gc",
    )
    occupancy_cache_ttl: int = Field(
        7 * DAY, ge=1, le=365 * DAY, description="Redis occupancy cache TTL (s)"
    )
    clip_cache_mb: int = Field(
        256,
        ge=1,
        le=MIB_PER_TIB,
        description="per-process memory (MB) for cached occupancy grids of a loaded graph",
    )
    flower_basic_auth: str = Field(
        "",
        description="`srg flower`'s HTTP basic auth, user:password[,user:password...]; '': "
        "none (Flower's own /api then answers only with FLOWER_UNAUTHENTICATED_API set)",
    )

    @field_validator("task_soft_time_limit")
    @classmethod
    def _soft_before_hard(cls, value: int, info: ValidationInfo) -> int:
        """A soft limit at or past the hard one never fires: the task is killed unwarned."""
        hard = info.data.get("task_time_limit")
        if hard is not None and value >= hard:
            raise ValueError(f"must be below SRG_TASK_TIME_LIMIT ({hard} s), got {value} s")
        return value

    @field_validator("flower_basic_auth")
    @classmethod
    def _user_password_pairs(cls, value: str) -> str:
        """Flower compares ``user:password`` with what a browser sends and splits the list
        at commas, so an entry without a user or a password would never match: refused
        here, before Flower starts. The message never repeats the value (a password)."""
        pairs = [pair.strip() for pair in value.split(",")] if value.strip() else []
        for pair in pairs:
            user, _, password = pair.partition(":")
            if not user or not password:
                raise ValueError("each entry must be user:password (a comma between entries)")
        return ",".join(pairs)

    @property
    def visibility_timeout(self) -> int:
        """Redis broker visibility timeout: well above the longest hard time limit.

        An unacknowledged (acks_late) message goes back to the queue only after this, so
        it must outlast any task still running, or a slow task would run twice at once.
        """
        return max(3600, 4 * self.task_time_limit)


class ApiSettings(BaseSettings):
    """What the HTTP API accepts, from whom and how often (docs/play.md)."""

    model_config = _SOURCES

    admin_token: str = Field(
        "", description="bearer token of the admin routes; '' (no default secret): routes off"
    )
    max_trace_bytes: int = Field(
        1_000_000, ge=1, le=GIB, description="body bytes of one trace upload, at most"
    )
    max_trace_steps: int = Field(
        2_000,
        ge=1,
        le=1_000_000,
        description="steps per uploaded trace (the web client sends <= 1,800)",
    )
    uploads_per_minute: int = Field(
        60, ge=1, le=1_000_000, description="trace uploads per player per minute, at most"
    )
    max_body_bytes: int = Field(
        16_384, ge=1, le=GIB, description="bodies of every request but trace uploads (413 beyond)"
    )
    address_upload_rate: RateLimits = Field(
        "600/minute",
        description="trace uploads per client address, in the `limits` notation "
        "('600/minute', '10/second;600/minute'); IPv6 addresses count per /64",
    )
    registration_rate: RateLimits = Field(
        "10/minute;100/day", description="player registrations per client address (`limits`)"
    )
    rate_limit_storage: str = Field(
        "",
        description="`limits` storage URI of the rate limits (redis://..., memory://); "
        "'': the Redis of redis_url (or of the broker) when there is one, else memory://",
    )
    trusted_proxies: str = Field(
        "",
        description="comma-separated addresses or networks of the reverse proxies whose "
        "X-Forwarded-For is honoured; '': none, the peer address is the client's",
    )
    cors_origins: WebOrigins = Field(
        "",
        description="comma-separated origins allowed by CORS, each http(s)://host[:port] "
        "('*': any); '': CORS off",
    )

    @property
    def admin_routes_on(self) -> bool:
        """Admin routes answer only once a token is configured: there is no default one."""
        return bool(self.admin_token.strip())


#: the fields of ``Settings`` that hold a group, and the group each holds
_GROUPS: dict[str, type[BaseSettings]] = {
    "growth": GrowthSettings,
    "render": RenderSettings,
    "runtime": RuntimeSettings,
    "api": ApiSettings,
}


class Settings(BaseSettings):
    """Where the data lives and which broker carries the work, and the four groups.

    Every field of every group is read from its own ``SRG_<FIELD>`` variable: the groups
    arrange the code's view, not the environment's names (docs/design.md, "Settings").
    """

    model_config = _SOURCES

    var_dir: DirectoryPath = Field(
        Path("var"), description="where the embedded SQLite database and the artifacts live"
    )
    database_url: DatabaseURL = Field(
        "", description="postgresql+psycopg://... or sqlite:///...; '': SQLite under var_dir"
    )
    artifact_dir: Path | None = Field(
        None,
        description="content-addressed clip bundles and animations, the same directory on "
        "every machine; unset: var_dir/data",
    )
    broker_url: BrokerURL = Field(
        "", description="Celery's broker (redis://...); '': tasks run eagerly, in-process"
    )
    result_backend: str = Field("", description="Celery's result backend; '': the broker")
    redis_url: RedisURL = Field("", description="redis://, rediss:// or unix://; '': none")
    scratch_postgres_url: PostgresURL = Field(
        "postgresql+psycopg://postgres@127.0.0.1:5432/srg_scratch",
        description="PostgreSQL server where `srg bench grow` and `srg bench writer` create "
        "their throwaway databases (its database name is replaced by theirs)",
    )

    growth: GrowthSettings = Field(default_factory=GrowthSettings)
    render: RenderSettings = Field(default_factory=RenderSettings)
    runtime: RuntimeSettings = Field(default_factory=RuntimeSettings)
    api: ApiSettings = Field(default_factory=ApiSettings)

    def __init__(self, **values: Any) -> None:
        """Read as pydantic-settings reads, but a ``.env`` that is not UTF-8 text is the
        operator's to fix, not a bug: an :class:`InvalidInput` naming the file."""
        try:
            super().__init__(**values)
        except UnicodeDecodeError as exc:
            raise InvalidInput(
                f"the settings file {_SOURCES['env_file']} is not UTF-8 text "
                f"(byte {exc.start + 1}): save it as UTF-8"
            ) from None

    @model_validator(mode="before")
    @classmethod
    def _read_groups(cls, data: Any) -> Any:
        """Every group not given read from the environment, all of them before an error
        is raised: a command names every bad variable at once, where each group's own
        default would stop at the first group with one."""
        if not isinstance(data, dict):
            return data
        errors: list[InitErrorDetails] = []
        for name, group in _GROUPS.items():
            if name not in data:
                try:
                    data[name] = group()
                except ValidationError as exc:
                    errors += [_as_detail(error) for error in exc.errors(include_url=False)]
        if errors:
            raise ValidationError.from_exception_data(cls.__name__, errors)
        return data

    def replace(self, **changes: object) -> Settings:
        """These settings with some fields changed, each named as its variable is
        (``batch_size=2``, wherever its group is) and validated as if read; an unknown
        name is an error, where ``model_copy`` would quietly add an attribute."""
        data = self.model_dump()
        for name, value in changes.items():
            if name in data:
                data[name] = value
                continue
            group = next((g for g in _GROUPS if name in data[g]), None)
            if group is None:
                raise TypeError(f"Settings have no field {name!r}")
            data[group][name] = value
        return Settings.model_validate(data)

    @property
    def resolved_database_url(self) -> str:
        if self.database_url:
            return self.database_url
        return f"sqlite:///{(self.var_dir / 'srg.sqlite3').resolve()}"

    @property
    def resolved_artifact_dir(self) -> Path:
        return self.artifact_dir if self.artifact_dir is not None else self.var_dir / "data"

    @property
    def resolved_redis_url(self) -> str:
        """Redis for caches and locks: ``redis_url``, else a ``redis://`` broker, else none."""
        if self.redis_url:
            return self.redis_url
        return self.broker_url if self.broker_url.startswith(("redis://", "rediss://")) else ""

    @property
    def eager(self) -> bool:
        """No broker configured means Celery runs every task in-process."""
        return not self.broker_url


#: the names of the settings classes, as a validation error gives its class
SETTINGS_CLASSES = frozenset([Settings.__name__, *(group.__name__ for group in _GROUPS.values())])


def _as_detail(error: ErrorDetails) -> InitErrorDetails:
    """One group's error, to be raised again among the others'."""
    detail = InitErrorDetails(type=error["type"], loc=error["loc"], input=error["input"])
    if "ctx" in error:
        detail["ctx"] = error["ctx"]
    return detail


def get_settings() -> Settings:
    """The settings of this process's environment, read now (a shell reads them where it
    starts a use case and hands them down; nothing caches them, so a change of the
    environment is seen by the next command or task without a reset)."""
    return Settings()
