"""The settings' groups: flat variable names in, grouped fields out, and validated copies."""

from __future__ import annotations

from pathlib import Path

import pytest
from pydantic import ValidationError

from app.config import ApiSettings, GrowthSettings, RenderSettings, RuntimeSettings, Settings
from app.core.errors import InvalidInput


def test_each_group_reads_its_fields_from_their_flat_variables(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    for name, value in {
        "SRG_BATCH_SIZE": "7",
        "SRG_GROWTH_RENDERS": "false",
        "SRG_TASK_TIME_LIMIT": "1200",
        "SRG_MAX_TRACE_STEPS": "30",
        "SRG_DATABASE_URL": "sqlite:///x.sqlite3",
    }.items():
        monkeypatch.setenv(name, value)
    settings = Settings()
    assert settings.growth.batch_size == 7
    assert settings.render.growth_renders is False
    assert settings.runtime.task_time_limit == 1200
    assert settings.runtime.visibility_timeout == 4800
    assert settings.api.max_trace_steps == 30
    assert settings.database_url == "sqlite:///x.sqlite3"


def test_replace_changes_fields_by_name_wherever_their_group_is(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    for name in ("SRG_BATCH_SIZE", "SRG_ADMIN_TOKEN"):
        monkeypatch.delenv(name, raising=False)
    settings = Settings(var_dir="a")
    changed = settings.replace(var_dir="b", batch_size=2, admin_token="t", llvm_path="/l.so")
    assert (str(changed.var_dir), changed.growth.batch_size) == ("b", 2)
    assert (changed.api.admin_token, changed.render.llvm_path) == ("t", "/l.so")
    assert changed.api.admin_routes_on and not settings.api.admin_routes_on
    assert (str(settings.var_dir), settings.growth.batch_size) == ("a", 4)  # untouched


def test_replace_validates_and_refuses_an_unknown_name() -> None:
    with pytest.raises(ValidationError, match="batch_size"):
        Settings().replace(batch_size=0)
    with pytest.raises(TypeError, match="'strategy'"):
        Settings().replace(strategy="max-error")


NUMBER_TYPES = (int, float)


def test_every_numeric_setting_has_both_bounds() -> None:
    """A number without an upper bound takes 20 digits and fails far from its variable."""
    fields = {
        name: field
        for cls in (Settings, GrowthSettings, RenderSettings, RuntimeSettings, ApiSettings)
        for name, field in cls.model_fields.items()
    }
    numeric = {name: f for name, f in fields.items() if f.annotation in NUMBER_TYPES}
    assert len(numeric) > 20
    for name, field in numeric.items():
        bounds = {type(bound).__name__ for bound in field.metadata}
        assert bounds & {"Ge", "Gt"} and bounds & {"Le", "Lt"}, name


@pytest.mark.parametrize(
    ("variable", "value", "says"),
    [
        ("SRG_DATABASE_URL", "mysql://user:secret@x/y", "must start with one of postgresql://"),
        ("SRG_DATABASE_URL", "garbage", "must start with one of"),
        ("SRG_SCRATCH_POSTGRES_URL", "sqlite:///x.sqlite3", "must start with one of postgresql"),
        ("SRG_REDIS_URL", "bogus", "must start with one of redis://"),
        ("SRG_RENDER_VARIANT", "bogus", "'auto', 'scalar_rgb' or 'llvm_ad_rgb'"),
        ("SRG_REGISTRATION_RATE", "0/minute", "a count of at least 1"),
        ("SRG_ADDRESS_UPLOAD_RATE", "10/second;0/minute", "a count of at least 1"),
        ("SRG_ADDRESS_UPLOAD_RATE", "10/0 minutes", "a count of at least 1"),
        ("SRG_REGISTRATION_RATE", "often", "COUNT/PERIOD"),
        ("SRG_TASK_SOFT_TIME_LIMIT", "1000", "below SRG_TASK_TIME_LIMIT (900 s)"),
        ("SRG_TASK_SOFT_TIME_LIMIT", "900", "below SRG_TASK_TIME_LIMIT (900 s)"),
        ("SRG_BATCH_SIZE", "9" * 20, "less than or equal to 1000"),
        ("SRG_SIMULATE_BATCH", "0", "greater than or equal to 1"),
        ("SRG_MAX_TRACE_BYTES", "9" * 20, "less than or equal to"),
        ("SRG_OCCUPANCY_CACHE_TTL", "9" * 20, "less than or equal to"),
        ("SRG_DEDUP_ERROR_FRACTION", "1.5", "less than or equal to 1"),
        ("SRG_CORS_ORIGINS", "javascript:alert(1)", "http(s)://host[:port]"),
        ("SRG_CORS_ORIGINS", "https://game.example/", "http(s)://host[:port]"),
        ("SRG_CORS_ORIGINS", "https://game.example, https://user@b.example", "http(s)://"),
        ("SRG_CORS_ORIGINS", "https://game.example:99999", "http(s)://host[:port]"),
        ("SRG_CORS_ORIGINS", "ftp://game.example", "http(s)://host[:port]"),
    ],
)
def test_a_bad_setting_is_refused_naming_its_field(
    monkeypatch: pytest.MonkeyPatch, variable: str, value: str, says: str
) -> None:
    monkeypatch.setenv(variable, value)
    with pytest.raises(ValidationError) as refused:
        Settings()
    (error,) = refused.value.errors()
    assert f"SRG_{str(error['loc'][-1]).upper()}" == variable
    assert says in error["msg"]
    assert "secret" not in error["msg"]


def test_good_values_of_the_checked_settings_are_taken(monkeypatch: pytest.MonkeyPatch) -> None:
    for name, value in {
        "SRG_DATABASE_URL": "postgresql://postgres@127.0.0.1:5432/srg",
        "SRG_REDIS_URL": "rediss://cache.example:6380/2",
        "SRG_RENDER_VARIANT": "llvm_ad_rgb",
        "SRG_REGISTRATION_RATE": "10 per 2 minutes|100/day",
        "SRG_ADDRESS_UPLOAD_RATE": "10/second, 600/minute",
        "SRG_TASK_SOFT_TIME_LIMIT": "899",
        "SRG_CORS_ORIGINS": " https://game.example ,http://127.0.0.1:8000,",
    }.items():
        monkeypatch.setenv(name, value)
    settings = Settings()
    assert settings.render.render_variant == "llvm_ad_rgb"
    assert settings.runtime.task_soft_time_limit == 899
    assert settings.api.cors_origins == "https://game.example,http://127.0.0.1:8000"
    assert Settings().replace(cors_origins="*").api.cors_origins == "*"


def test_a_settings_file_that_is_not_utf8_is_an_invalid_input(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / ".env").write_bytes(b"SRG_BATCH_SIZE=3\nSRG_ADMIN_TOKEN=\xff\xfe\n")
    with pytest.raises(InvalidInput, match=r"\.env is not UTF-8 text \(byte 34\)"):
        Settings()
    (tmp_path / ".env").write_text("SRG_BATCH_SIZE=3\nSRG_ADMIN_TOKEN=t\u00e9\n")
    assert (Settings().growth.batch_size, Settings().api.admin_token) == (3, "t\u00e9")
