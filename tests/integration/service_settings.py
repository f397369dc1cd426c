"""Settings for the tests of services, which are handed Settings (docs/design.md).

- :func:`session_settings`: the database of the rolled-back ``session`` of
  tests/conftest.py, for a service that works in the session it is given and reads only
  the dynamics, thresholds and artifacts from its Settings;
- :func:`committed_settings`: a fresh migrated database of its own, for a service that
  opens its own transactions (``transaction(settings)``, ``database_sessions(settings)``:
  ``srg gc``, ``srg fsck``, ``srg demo``), which a rolled-back session cannot hold
  (SQLite: a file under the folder given; PostgreSQL: a throwaway database, dropped
  afterwards).

Either way the artifacts live under the folder given, and the graph cache (keyed by
graph id, which every fresh or rolled-back database counts from 1 again) is emptied
before and after.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from database_helpers import migrate, postgres_base_url, postgres_database

from app.config import Settings
from app.db.engines import dispose_engines
from app.services.graph_cache import graph_cache

BACKENDS = ["sqlite", pytest.param("postgresql", marks=pytest.mark.postgres)]


def session_settings(db_url: str, folder: Path, **changes: object) -> Iterator[Settings]:
    """Settings of the (rolled-back) database ``db_url``, artifacts under ``folder``;
    ``changes`` as :meth:`Settings.replace` takes them."""
    var = folder / "var"
    var.mkdir(parents=True, exist_ok=True)
    graph_cache.clear()
    try:
        yield Settings().replace(
            database_url=db_url, var_dir=var, artifact_dir=folder / "artifacts", **changes
        )
    finally:
        graph_cache.clear()


def _sqlite_database(folder: Path) -> Iterator[str]:
    url = f"sqlite:///{folder / 'srg.sqlite3'}"
    migrate(url)
    yield url


def committed_settings(backend: str, folder: Path) -> Iterator[Settings]:
    """Settings of a new database of ``backend`` migrated to head, artifacts under
    ``folder``, no renders while growing; the app's engines closed afterwards."""
    var = folder / "var"
    var.mkdir(parents=True, exist_ok=True)
    urls = (
        _sqlite_database(folder)
        if backend == "sqlite"
        else postgres_database(postgres_base_url(), migrated=True)
    )
    for url in urls:  # one URL; the loop's next step drops a PostgreSQL database
        graph_cache.clear()
        try:
            yield Settings().replace(
                database_url=url,
                var_dir=var,
                artifact_dir=folder / "artifacts",
                growth_renders=False,
                broker_url="",
            )
        finally:
            dispose_engines()
            graph_cache.clear()
