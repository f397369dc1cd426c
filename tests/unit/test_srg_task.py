"""Every srg task works in the settings read as its call starts (app.tasks.celery_app):
one reading a call, and a changed environment seen by the next call."""

from __future__ import annotations

from pathlib import Path

import pytest

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
