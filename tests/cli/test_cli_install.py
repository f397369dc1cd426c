"""What an installed ``srg`` says about itself: its version, and the extra a command needs
when that extra is not installed (one line, exit 2, nothing else printed on stderr)."""

from __future__ import annotations

import os
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
from cli_helpers import ok, one_line_error

ROOT = Path(__file__).resolve().parents[2]
#: runs ``srg ARGS`` as the console script does, the module named first not installed
#: (``None`` in sys.modules: importing it raises ModuleNotFoundError, as when absent)
WITHOUT = (
    "import sys; sys.modules[sys.argv[1]] = None; sys.argv = ['srg', *sys.argv[2:]]; "
    "from app.cli.main import main; main()"
)


def test_version_prints_the_project_version(tmp_path: Path) -> None:
    version = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    assert ok(tmp_path, "--version") == f"srg {version}\n"


@pytest.mark.parametrize(
    ("module", "args", "extra"),
    [
        ("pyopencl", ["validate", "--preset", "tiny"], "sim"),
        ("celery", ["worker"], "cluster"),
        ("fastapi", ["serve", "--port", "8765"], "api"),
        ("matplotlib", ["demo", "--dynamics", "toy", "--checkpoints", "60"], "plots"),
    ],
)
def test_a_command_without_its_extra_names_the_extra_to_install(
    tmp_path: Path, module: str, args: list[str], extra: str
) -> None:
    env = {k: v for k, v in os.environ.items() if not k.startswith("SRG_")}
    env["SRG_VAR_DIR"] = str(tmp_path)
    done = subprocess.run(
        [sys.executable, "-c", WITHOUT, module, *args], env=env, capture_output=True, text=True
    )
    one_line_error(done, f"needs the '{extra}' extra ({module} is not installed)")
    assert done.stderr.endswith(f"pip install 'srg[{extra}]'\n")
    assert done.stderr.count("\n") == 1
