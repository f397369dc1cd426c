"""Every bad setting is one ``srg: error:`` line naming its variable, before any work: the
values an operator reported as a traceback or as silently taken."""

from __future__ import annotations

from pathlib import Path

import pytest
from cli_helpers import one_line_error, srg


@pytest.mark.parametrize(
    ("variable", "value"),
    [
        ("SRG_DATABASE_URL", "mysql://x/y"),
        ("SRG_RENDER_VARIANT", "bogus"),
        ("SRG_REGISTRATION_RATE", "0/minute"),
        ("SRG_TASK_SOFT_TIME_LIMIT", "1000"),
        ("SRG_BATCH_SIZE", "9" * 20),
        ("SRG_CORS_ORIGINS", "javascript:alert(1)"),
        ("SRG_REDIS_URL", "bogus"),
    ],
)
@pytest.mark.parametrize("command", [["status"], ["init", "g"], ["serve"]])
def test_a_bad_setting_is_one_line_naming_its_variable_and_nothing_is_made(
    tmp_path: Path, variable: str, value: str, command: list[str]
) -> None:
    one_line_error(srg(tmp_path, *command, **{variable: value}), f"{variable}: ")
    assert not (tmp_path / "srg.sqlite3").exists()


def test_a_settings_file_that_is_not_utf8_is_one_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / ".env").write_bytes(b"SRG_BATCH_SIZE=3\n# caf\xe9 in Latin-1\n")
    one_line_error(srg(tmp_path / "var", "status"), "the settings file .env is not UTF-8 text")
    assert not (tmp_path / "var").exists()
