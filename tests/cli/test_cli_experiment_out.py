"""``srg experiment`` refuses a report or result path it could not write before it grows
anything: the refusal used to come after the whole run."""

from __future__ import annotations

from pathlib import Path

import pytest
from cli_helpers import ok, one_line_error, srg


@pytest.mark.parametrize(
    ("option", "under_file", "says"),
    [
        ("--out", "x", "is not a directory"),
        ("--out", "", "is not a directory"),
        ("--result", "x/result.json", "is not a directory"),
    ],
)
def test_a_path_under_a_regular_file_is_refused_before_any_work(
    tmp_path: Path, option: str, under_file: str, says: str
) -> None:
    ok(tmp_path, "db", "upgrade")
    blocker = tmp_path / "a-file"
    blocker.write_text("not a directory\n")
    path = blocker / under_file if under_file else blocker
    done = srg(tmp_path, "experiment", "--quick", "--name", "refused", option, str(path))
    one_line_error(done, f"{option} {path}: {blocker} {says}")
    assert "refused" not in ok(tmp_path, "status")
    assert blocker.read_text() == "not a directory\n"


def test_a_result_path_that_is_a_directory_is_refused(tmp_path: Path) -> None:
    ok(tmp_path, "db", "upgrade")
    done = srg(tmp_path, "experiment", "--quick", "--result", str(tmp_path))
    one_line_error(done, f"--result {tmp_path} is a directory")
    assert "experiment" not in ok(tmp_path, "status")
