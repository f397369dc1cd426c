"""The layers of ``app`` (docs/design.md, "Runtime"), held by import-linter's contracts.

The contracts live in ``pyproject.toml`` (``[tool.importlinter]``): the core imports
nothing of ``app``, nothing imports the CLI, services import neither the shells nor the
benchmarks, no import circles at any depth, and the layers from the CLI down to the core.
Function-level imports count: an arrow hidden inside a function is still an arrow.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
LINT_IMPORTS = Path(sys.executable).with_name("lint-imports")
CONTRACTS = 5


def lint_imports(tree: Path) -> subprocess.CompletedProcess[str]:
    """``lint-imports`` on the ``app`` package under ``tree``, with the project's contracts."""
    return subprocess.run(
        [str(LINT_IMPORTS), "--config", str(ROOT / "pyproject.toml"), "--no-cache"],
        cwd=tree,
        capture_output=True,
        text=True,
        check=False,
    )


def test_the_code_keeps_every_contract() -> None:
    done = lint_imports(ROOT)
    assert done.returncode == 0, done.stdout + done.stderr
    assert f"Contracts: {CONTRACTS} kept, 0 broken." in done.stdout


def test_an_arrow_back_up_breaks_the_contracts(tmp_path: Path) -> None:
    # a copy of the package's modules, with the core importing the CLI (which imports the
    # core: a circle too) and a service importing the tasks
    shutil.copytree(
        ROOT / "app",
        tmp_path / "app",
        ignore=lambda folder, names: [
            n for n in names if not n.endswith(".py") and not (Path(folder) / n).is_dir()
        ],
    )
    (tmp_path / "app" / "core" / "upward.py").write_text("import app.cli.main\n")
    (tmp_path / "app" / "services" / "upward.py").write_text("import app.tasks\n")
    done = lint_imports(tmp_path)
    assert done.returncode == 1, done.stdout + done.stderr
    assert f"Contracts: 0 kept, {CONTRACTS} broken." in done.stdout, done.stdout
    assert "app.core.upward -> app.cli.main" in done.stdout
    assert "app.services.upward -> app.tasks" in done.stdout
