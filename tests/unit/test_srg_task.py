"""Every srg task works in the settings read as its call starts (app.tasks.celery_app):
one reading a call, a changed environment seen by the next call, and each step's scope
made of that call's settings and artifact store."""

from __future__ import annotations

from pathlib import Path

import pytest
from sqlalchemy import text

from app.tasks.celery_app import SrgTask, celery_app


@celery_app.task(name="tests.var_dir_seen", bind=True)
def var_dir_seen(self: SrgTask) -> str:
    return str(self.settings.var_dir)


def test_a_task_works_in_the_settings_of_its_own_call(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setenv("SRG_VAR_DIR", str(tmp_path / "first"))
    assert var_dir_seen.apply().get() == str(tmp_path / "first")
    monkeypatch.setenv("SRG_VAR_DIR", str(tmp_path / "second"))
    assert var_dir_seen.apply().get() == str(tmp_path / "second")


@celery_app.task(name="tests.scope_seen", bind=True)
def scope_seen(self: SrgTask) -> list[str]:
    with self.scope() as scope:
        scope.session.execute(text("SELECT 1"))
        return [str(scope.settings.var_dir), str(scope.artifacts.root)]


def test_a_tasks_scope_holds_its_calls_settings_and_their_artifact_store(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    for var in ("first", "second"):
        monkeypatch.setenv("SRG_VAR_DIR", str(tmp_path / var))
        monkeypatch.delenv("SRG_DATABASE_URL", raising=False)
        monkeypatch.delenv("SRG_ARTIFACT_DIR", raising=False)
        seen = scope_seen.apply().get()
        assert seen[0] == str(tmp_path / var)
        assert Path(seen[1]).is_relative_to(tmp_path / var)
