"""The engine of a Settings: one per database and process, the oldest of too many closed."""

from __future__ import annotations

from pathlib import Path

from sqlalchemy import text

from app.config import Settings
from app.db.engines import ENGINES_KEPT, database_engine, dispose_engines
from app.db.sessions import transaction


def test_each_database_gets_its_engine_and_a_service_reaches_it_by_its_settings(
    tmp_path: Path,
) -> None:
    dispose_engines()
    first, second = Settings(var_dir=tmp_path / "a"), Settings(var_dir=tmp_path / "b")
    assert database_engine(first) is database_engine(first.model_copy())  # one pool each
    assert database_engine(first) is not database_engine(second)
    with transaction(second) as session:  # the embedded default, migrated on first use
        session.execute(
            text("INSERT INTO players (name, kind, token_hash) VALUES ('p', 'bot', 'x')")
        )
    with transaction(first) as session:
        assert session.execute(text("SELECT count(*) FROM players")).scalar() == 0
    with transaction(second) as session:
        assert session.execute(text("SELECT count(*) FROM players")).scalar() == 1
    dispose_engines()


def test_the_least_recently_used_engine_is_disposed_past_the_kept_number(tmp_path: Path) -> None:
    dispose_engines()
    settings = [Settings(var_dir=tmp_path / str(i)) for i in range(ENGINES_KEPT + 1)]
    oldest = database_engine(settings[0])
    with oldest.connect():
        pass
    assert oldest.pool.checkedin() == 1
    for later in settings[1:]:
        database_engine(later)
    assert oldest.pool.checkedin() == 0  # disposed: its connections closed
    assert database_engine(settings[0]) is not oldest  # made again when asked again
    dispose_engines()
