"""Running `srg` in-process the way the console script does, and checking its errors."""

from __future__ import annotations

import contextlib
import io
import subprocess
import sys
from pathlib import Path

import pytest

from app.cli.main import main
from app.db.engines import dispose_engines

SRG = Path(sys.executable).with_name("srg")


def srg(var: Path, *args: str, **env: str) -> subprocess.CompletedProcess[str]:
    """Run ``srg args`` in this process with SRG_VAR_DIR=var (and ``env``) set."""
    with pytest.MonkeyPatch.context() as patch:
        patch.delenv("SRG_DATABASE_URL", raising=False)
        for key, value in {"SRG_VAR_DIR": str(var), **env}.items():
            patch.setenv(key, value)
        patch.setattr(sys, "argv", ["srg", *args])
        out, err = io.StringIO(), io.StringIO()
        code = 0
        try:
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                main()
        except SystemExit as exit_:
            code = exit_.code if isinstance(exit_.code, int) else 1
        finally:
            dispose_engines()  # the command's: its database file goes with the test
    return subprocess.CompletedProcess(args, code, out.getvalue(), err.getvalue())


def ok(var: Path, *args: str) -> str:
    done = srg(var, *args)
    assert done.returncode == 0, done.stderr
    return done.stdout


def one_line_error(done: subprocess.CompletedProcess[str], fragment: str) -> None:
    assert done.returncode == 2, done.stdout + done.stderr
    errors = [line for line in done.stderr.splitlines() if line.startswith("srg: error:")]
    assert len(errors) == 1 and fragment in errors[0], done.stderr
    assert "Traceback" not in done.stderr
