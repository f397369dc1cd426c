"""`srg beat` keeps its state under SRG_VAR_DIR and makes the directory (it crashed on a
missing ./var before)."""

from __future__ import annotations

from pathlib import Path

from app.cli.runtime import beat_state_file


def test_the_beat_state_file_lives_in_the_var_dir_which_is_made(tmp_path: Path) -> None:
    var = tmp_path / "fresh" / "var"
    state = beat_state_file(var, None)
    assert state == var / "celerybeat-schedule" and var.is_dir()
    chosen = beat_state_file(var, tmp_path / "elsewhere" / "beat.db")
    assert chosen.parent.is_dir() and chosen.name == "beat.db"
