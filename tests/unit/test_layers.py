"""The layers of ``app`` (docs/design.md, "Runtime"), held by import-linter's contracts.

The contracts live in ``pyproject.toml`` (``[tool.importlinter]``): the core imports
nothing of ``app``, its five domains import only those below them, the learned player
models import no bot's policy (every model the registry holds, checked here), nothing
imports the CLI, services import neither the shells nor the benchmarks, the API, the tasks
and the CLI reach the store only through services, no import circles at any depth, and the
layers from the CLI down to the core.
Function-level imports count: an arrow hidden inside a function is still an arrow.

Import-linter sees packages, not statements, so one rule is checked here by reading the
code: SQL is written only in the store (and the models and engines beneath it).
"""

from __future__ import annotations

import ast
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

from app.core.players.crowd_models.registry import CROWD_MODELS

ROOT = Path(__file__).resolve().parents[2]
LINT_IMPORTS = Path(sys.executable).with_name("lint-imports")
CONTRACTS = 8
#: the contract that keeps every crowd model from the bots' policies
LEARNED_MODELS = "the learned player models import no bot's policy"
#: where SQL may be written: the store, the tables, the engines, and the benchmarks'
#: throwaway databases (``CREATE DATABASE`` on a scratch server)
SQL_HOMES = ("app/store/", "app/models/", "app/db/", "app/bench/scratch.py")
#: SQLAlchemy's statement builders
SQL_BUILDERS = {
    "select", "insert", "update", "delete", "text", "func", "distinct", "and_", "or_",
    "exists", "literal", "case", "union", "bindparam",
}  # fmt: skip
#: a session's or connection's ways to run a statement or touch a row
SQL_CALLS = {"execute", "scalar", "scalars", "query", "merge", "add", "add_all"}


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
    # core: a circle too), the graph domain importing evaluation, a service importing the
    # tasks, a player model the bots and a route the store
    shutil.copytree(
        ROOT / "app",
        tmp_path / "app",
        ignore=lambda folder, names: [
            n for n in names if not n.endswith(".py") and not (Path(folder) / n).is_dir()
        ],
    )
    (tmp_path / "app" / "core" / "upward.py").write_text("import app.cli.main\n")
    (tmp_path / "app" / "core" / "graph" / "upward.py").write_text(
        "import app.core.evaluation.metrics\n"
    )
    (tmp_path / "app" / "services" / "upward.py").write_text("import app.tasks\n")
    model = tmp_path / "app" / "core" / "players" / "crowd_models" / "shrunk.py"
    model.write_text(model.read_text() + "\nimport app.core.players.bots\n")
    (tmp_path / "app" / "api" / "routes" / "upward.py").write_text("import app.store.traces\n")
    done = lint_imports(tmp_path)
    assert done.returncode == 1, done.stdout + done.stderr
    assert f"Contracts: 0 kept, {CONTRACTS} broken." in done.stdout, done.stdout
    assert "app.core.upward -> app.cli.main" in done.stdout
    assert "app.core.graph.upward -> app.core.evaluation.metrics" in done.stdout
    assert "app.services.upward -> app.tasks" in done.stdout
    assert "app.core.players.crowd_models.shrunk -> app.core.players.bots" in done.stdout
    assert "app.api.routes.upward -> app.store.traces" in done.stdout


def contract(name: str) -> dict[str, object]:
    """The import-linter contract called ``name`` in ``pyproject.toml``."""
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())
    (found,) = (c for c in config["tool"]["importlinter"]["contracts"] if c["name"] == name)
    return dict(found)


def held_by(module: str, sources: list[str]) -> bool:
    """Whether ``module`` is one of ``sources`` or lies in one (import-linter's packages)."""
    return any(module == source or module.startswith(f"{source}.") for source in sources)


def test_the_contract_on_the_bots_holds_every_registered_crowd_model() -> None:
    """The models the contract holds are the registry's, wherever a model's module is: one
    registered from outside the contract's packages is not judged fairly by the bots."""
    sources = contract(LEARNED_MODELS)["source_modules"]
    assert isinstance(sources, list)
    outside = [m.__module__ for m in CROWD_MODELS.values() if not held_by(m.__module__, sources)]
    assert outside == []


def sql_outside_the_store(root: Path) -> list[str]:
    """``path:line what`` for each statement builder imported, or statement run, outside
    :data:`SQL_HOMES` (a call counts when made on something named ``session``, or is
    ``execute``/``scalar(s)`` on anything)."""
    found = []
    for path in sorted((root / "app").rglob("*.py")):
        where = path.relative_to(root).as_posix()
        if where.startswith(SQL_HOMES):
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("sqlalchemy"):
                found += [
                    f"{where}:{node.lineno} {a.name}" for a in node.names if a.name in SQL_BUILDERS
                ]
            elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute):
                name, owner = node.func.attr, node.func.value
                on_session = isinstance(owner, ast.Name) and owner.id == "session"
                if name in {"execute", "scalar", "scalars"} or (
                    on_session and name in SQL_CALLS | {"get", "delete"}
                ):
                    found.append(f"{where}:{node.lineno} .{name}()")
    return found


def test_only_the_store_writes_sql() -> None:
    assert sql_outside_the_store(ROOT) == []


def test_sql_in_a_service_is_found(tmp_path: Path) -> None:
    (tmp_path / "app" / "services").mkdir(parents=True)
    (tmp_path / "app" / "services" / "leak.py").write_text(
        "from sqlalchemy import select\n\n\ndef f(session):\n    return session.get(1)\n"
    )
    assert sql_outside_the_store(tmp_path) == [
        "app/services/leak.py:1 select",
        "app/services/leak.py:5 .get()",
    ]
