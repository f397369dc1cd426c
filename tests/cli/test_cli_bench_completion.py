"""`srg bench completion`: a tab completion as the shell runs it, timed, and the
candidates it printed; the figure is a benchmark's, never a test's bar."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from cli_helpers import ok, one_line_error, srg


def test_the_benchmark_completes_as_the_shell_would_and_reports_against_the_target(
    tmp_path: Path,
) -> None:
    report = json.loads(ok(tmp_path, "bench", "completion", "--repeats", "1", "--line", "srg exp"))
    assert report["candidates"] == ["experiment"]
    assert report["target_seconds"] == 0.3
    assert report["met"] == (report["completion_wall_seconds"] <= 0.3)
    assert report["completion_cpu_seconds"] > 0 and report["import_cli_wall_seconds"] > 0
    assert report["provenance"]["command"]


def test_a_line_of_another_program_is_refused(tmp_path: Path) -> None:
    one_line_error(srg(tmp_path, "bench", "completion", "--line", "ls -l"), "--line completes")


def test_the_cli_is_declared_without_the_numerics_or_the_database() -> None:
    """What a tab completion imports: the command tree and its options' choices and
    ranges, never NumPy, SciPy, SQLAlchemy, the settings or rich (each imported by the
    command that runs, not by the declaration every completion reads)."""
    heavy = ("numpy", "scipy", "sqlalchemy", "pydantic_settings", "app.config", "rich")
    probe = f"import sys, app.cli.main; print([m for m in {heavy!r} if m in sys.modules])"
    found = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True)
    assert found.returncode == 0, found.stderr
    assert found.stdout.strip() == "[]"
