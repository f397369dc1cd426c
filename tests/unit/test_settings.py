"""The settings' groups: flat variable names in, grouped fields out, and validated copies."""

from __future__ import annotations

import pytest
from pydantic import ValidationError

from app.config import Settings


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
