"""pyproject.toml's core and extras against what srg imports.

Every module that ``app`` (or its migrations' ``env.py``) imports from outside the
standard library comes with a core dependency, or with the extra that
:data:`app.cli.extras.EXTRA_OF_MODULE` names for it: the extra the one-line error of a
command without it tells the user to install. A module that only an extra's distribution
brings in (kombu with celery) counts as that extra's.
"""

from __future__ import annotations

import ast
import re
import sys
import tomllib
from collections.abc import Iterable
from importlib.metadata import PackageNotFoundError, packages_distributions, requires
from pathlib import Path

from app.cli.extras import EXTRA_OF_MODULE

ROOT = Path(__file__).resolve().parents[2]
PROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
EXTRAS = PROJECT["optional-dependencies"]
#: the extras of the product, which ``all`` gathers; ``test`` is the developers'
PRODUCT_EXTRAS = set(EXTRAS) - {"all", "test"}


def _name(requirement: str) -> str:
    """A requirement's distribution name, normalized (PEP 503)."""
    match = re.match(r"[A-Za-z0-9._-]+", requirement)
    assert match, requirement
    return re.sub(r"[-_.]+", "-", match.group()).lower()


def _brought(requirements: Iterable[str]) -> set[str]:
    """The distributions ``requirements`` install, with what those require in turn (a
    requirement of one of their own extras excepted)."""
    seen: set[str] = set()
    todo = [_name(r) for r in requirements]
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        seen.add(name)
        try:
            todo += [_name(r) for r in requires(name) or [] if "extra ==" not in r]
        except PackageNotFoundError:  # a requirement of another platform or Python
            continue
    return seen


def _imported_modules() -> set[str]:
    """The first-level names of the modules srg's own code imports, standard library out."""
    names = set()
    for path in [*(ROOT / "app").rglob("*.py"), ROOT / "alembic" / "env.py"]:
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names.update(alias.name.partition(".")[0] for alias in node.names)
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names.add(node.module.partition(".")[0])
    return names - set(sys.stdlib_module_names) - {"app"}


def test_every_module_srg_imports_comes_with_the_core_or_with_the_extra_named_for_it() -> None:
    core = _brought(PROJECT["dependencies"])
    distributions = packages_distributions()
    for module in sorted(_imported_modules()):
        brings = {_name(d) for d in distributions[module]}
        extra = EXTRA_OF_MODULE.get(module)
        if extra is None:
            assert brings & core, f"{module}: not in the core; name its extra in app.cli.extras"
        else:
            assert not brings & core, f"{module} comes with the core, not the {extra!r} extra"
            assert brings & _brought(EXTRAS[extra]), f"{module} is not in the {extra!r} extra"


def test_the_extras_table_names_only_modules_srg_imports() -> None:
    assert set(EXTRA_OF_MODULE) <= _imported_modules()
    assert set(EXTRA_OF_MODULE.values()) <= PRODUCT_EXTRAS


def test_all_gathers_every_extra_of_the_product() -> None:
    (everything,) = EXTRAS["all"]
    match = re.fullmatch(r"srg\[([a-z,]+)\]", everything)
    assert match and set(match.group(1).split(",")) == PRODUCT_EXTRAS


def test_the_quick_starts_extras_serve_the_docs_site() -> None:
    """The README sends a reader to `mkdocs serve` after the quick start, which installs
    ``all``: the site's engine and theme must come with it, not only with ``test``."""
    gathered = re.search(r"\[(.*)\]", EXTRAS["all"][0])
    assert gathered is not None and "docs" in gathered.group(1).split(",")
    assert {"mkdocs", "mkdocs-material"} <= {_name(r) for r in EXTRAS["docs"]}
