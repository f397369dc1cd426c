"""SQLite's growth claim is the database file's, however a grower names that file.

The finding: the claim's lock file was named after the path string, so a grower that
reached the database through a symlink took a claim of its own and grew beside the
first, and was refused later for a wrong reason rather than at once for the true one.
"""

from __future__ import annotations

import sqlite3
from pathlib import Path

import pytest

from app.db.engines import make_engine
from app.store.growth_claims import GrowingElsewhere, growth_claim, refuse_if_claimed

GROWN_ELSEWHERE = "graph 'g' is being grown by another process"


def test_a_symlink_to_the_database_file_shares_its_growth_claim(tmp_path: Path) -> None:
    real = tmp_path / "srg.sqlite3"
    sqlite3.connect(real).close()
    link = tmp_path / "elsewhere" / "link.sqlite3"
    link.parent.mkdir()
    link.symlink_to(real)
    engine, through_link = make_engine(f"sqlite:///{real}"), make_engine(f"sqlite:///{link}")
    try:
        with growth_claim(engine, 1, "g"):
            with pytest.raises(GrowingElsewhere, match=GROWN_ELSEWHERE):
                refuse_if_claimed(through_link, 1, "g")
            with (
                pytest.raises(GrowingElsewhere, match=GROWN_ELSEWHERE),
                growth_claim(through_link, 1, "g"),
            ):
                pytest.fail("two growers of one graph at once")
            with growth_claim(through_link, 2, "h"):  # another graph's claim is its own
                pass
        with growth_claim(through_link, 1, "g"):  # released with the first grower
            pass
    finally:
        engine.dispose()
        through_link.dispose()
