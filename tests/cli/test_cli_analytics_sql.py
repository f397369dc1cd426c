"""docs/analytics.md's questions in SQL over the analytics views (migration 0011), run as
written on SQLite and on PostgreSQL and held to what ``srg analytics`` says of the same
play; the lookup of edge kinds; a comment on every table, view and column of PostgreSQL."""

from __future__ import annotations

import json
import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from cli_helpers import srg
from database_helpers import postgres_base_url, postgres_database
from sqlalchemy import select, text
from sqlalchemy.orm import Session

from app.config import Settings
from app.core.graph.state_graph import EdgeKind
from app.core.players.bots import play_sessions
from app.core.players.kinds import BotKind, PlayerKind
from app.db.engines import make_engine
from app.models import Graph
from app.store.publications import latest_publication, load_publication
from app.store.traces import get_or_create_player, record_trace

DOC = Path(__file__).resolve().parents[2] / "docs" / "analytics.md"
QUERIES = re.findall(r"```sql\n(.*?)```", DOC.read_text(), re.DOTALL)
#: the graph the documented queries name
GRAPH = "mygraph"
PEOPLE_SESSIONS = 4
BOT_SESSIONS = 8
#: the selection of `srg analytics --players` that is each player kind's sessions
SELECTION = {PlayerKind.PERSON.value: "people", PlayerKind.BOT.value: "bots"}


@dataclass(frozen=True)
class Played:
    """A database where ``GRAPH`` was played by people and bots on two publications."""

    var: Path
    url: str

    def srg(self, *args: str) -> str:
        done = srg(self.var, *args, SRG_DATABASE_URL=self.url)
        assert done.returncode == 0, done.stderr
        return done.stdout

    def analytics(self, *args: str) -> dict[str, Any]:
        return dict(json.loads(self.srg("analytics", GRAPH, *args, "--json")))

    def query(self, sql: str) -> list[dict[str, Any]]:
        engine = make_engine(self.url)
        try:
            with engine.connect() as connection:
                return [dict(row) for row in connection.execute(text(sql)).mappings()]
        finally:
            engine.dispose()


def _play_as_people(url: str, graph: str, sessions: int) -> None:
    """People's sessions on the graph's latest publication, as the web client uploads them."""
    engine = make_engine(url)
    try:
        with Session(engine) as session:
            graph_id = session.scalars(select(Graph.id).where(Graph.name == graph)).one()
            row = latest_publication(session, graph_id)
            assert row is not None
            publication = load_publication(session, row.id)
            traces = play_sessions(
                publication, BotKind.RANDOM, sessions=sessions, mean_steps=30, seed=7
            )
            for i, trace in enumerate(traces):
                player, _ = get_or_create_player(session, f"person-{i}", PlayerKind.PERSON)
                record_trace(session, row.id, player, f"upload-{i}", trace, publication=publication)
            session.commit()
    finally:
        engine.dispose()


@pytest.fixture(
    scope="module", params=["sqlite", pytest.param("postgresql", marks=pytest.mark.postgres)]
)
def played(
    request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[Played]:
    var = tmp_path_factory.mktemp("analytics")
    if request.param == "sqlite":
        urls: Iterator[str] = iter([Settings(var_dir=var).resolved_database_url])
    else:
        urls = postgres_database(postgres_base_url())
    url = next(urls)
    db = Played(var, url)
    db.srg("db", "upgrade")
    db.srg("init", GRAPH)
    db.srg("grow", GRAPH, "--expansions", "4")
    db.srg("publish", GRAPH, "--no-render")
    _play_as_people(url, GRAPH, PEOPLE_SESSIONS)
    db.srg("play", GRAPH, "--sessions", str(BOT_SESSIONS), "--seed", "0")
    db.srg("grow", GRAPH, "--expansions", "4")
    db.srg("publish", GRAPH, "--no-render")
    db.srg("play", GRAPH, "--sessions", str(BOT_SESSIONS), "--seed", "1", "--bot", "random")
    db.srg("init", "other")  # play on another graph, which no query of GRAPH may count
    db.srg("publish", "other", "--no-render")
    db.srg("play", "other", "--sessions", "3", "--seed", "2")
    yield db
    next(urls, None)  # drops the PostgreSQL database


def test_the_page_asks_five_questions() -> None:
    assert len(QUERIES) == 5


def test_sessions_and_their_length_by_player_kind(played: Played) -> None:
    rows = played.query(QUERIES[0])
    report = played.analytics()
    assert {row["player_kind"]: row["sessions"] for row in rows} == report["sessions_by_kind"]
    assert report["sessions_by_kind"] == {"person": PEOPLE_SESSIONS, "bot": 2 * BOT_SESSIONS}
    for row in rows:
        lengths = played.analytics("--players", SELECTION[row["player_kind"]])["session_lengths"]
        assert float(row["mean_steps"]) == pytest.approx(lengths["mean"])


def _held_to_observed_error(rows: list[dict[str, Any]], observed: list[dict[str, Any]]) -> None:
    assert [row["publication_number"] for row in rows] == [o["number"] for o in observed]
    for row, figures in zip(rows, observed, strict=True):
        assert row["sessions"] == figures["sessions"]
        assert float(row["mean_error"]) == pytest.approx(figures["mean_error"])
        assert float(row["high_error_share"]) == pytest.approx(figures["high_error_fraction"])


def test_error_and_its_high_share_per_publication(played: Played) -> None:
    rows = played.query(QUERIES[1])
    report = played.analytics()
    _held_to_observed_error(rows, report["observed_error"])
    assert [row["steps"] for row in rows] == [o["steps"] for o in report["observed_error"]]
    # the threshold stored at publish time is the one analytics applies today
    assert [row["threshold"] for row in rows] == [pytest.approx(report["threshold"])] * 2


def test_error_of_people_beside_bots(played: Played) -> None:
    rows = played.query(QUERIES[2])
    assert {row["player_kind"] for row in rows} == {"person", "bot"}
    for kind, selection in SELECTION.items():
        observed = played.analytics("--players", selection)["observed_error"]
        _held_to_observed_error([row for row in rows if row["player_kind"] == kind], observed)


def test_error_by_edge_kind_adds_up_to_the_publications(played: Played) -> None:
    rows = played.query(QUERIES[3])
    assert {row["edge_kind_name"] for row in rows} == {"sim", "blend"}
    assert all(row["high_error_steps"] == 0 for row in rows if row["edge_kind_name"] == "sim")
    for figures in played.analytics()["observed_error"]:
        kinds = [row for row in rows if row["publication_number"] == figures["number"]]
        steps = sum(row["steps"] for row in kinds)
        assert steps == figures["steps"]
        error = sum(float(row["total_error"]) for row in kinds)
        assert error / steps == pytest.approx(figures["mean_error"])


def test_the_most_visited_vertices(played: Played) -> None:
    rows = played.query(QUERIES[4])
    visits = played.analytics()["visit_counts"][:10]
    assert [(r["vertex"], r["visits"], r["sessions"]) for r in rows] == [
        (v["vertex"], v["visits"], v["sessions"]) for v in visits
    ]


def test_the_edge_kinds_are_named_as_the_core_names_them(played: Played) -> None:
    rows = played.query("SELECT kind, name FROM edge_kinds ORDER BY kind")
    assert [(row["kind"], row["name"]) for row in rows] == [
        (kind.value, kind.name.lower()) for kind in EdgeKind
    ]


@pytest.mark.postgres
def test_every_table_view_and_column_of_postgresql_has_a_comment() -> None:
    for url in postgres_database(postgres_base_url(), migrated=True):
        engine = make_engine(url)
        try:
            with engine.connect() as connection:
                relations = connection.execute(
                    text("""
                    SELECT c.relname, obj_description(c.oid, 'pg_class') IS NOT NULL
                    FROM pg_class c JOIN pg_namespace n ON n.oid = c.relnamespace
                    WHERE n.nspname = 'public' AND c.relkind IN ('r', 'v')
                      AND c.relname <> 'alembic_version'
                    """)
                ).all()
                columns = connection.execute(
                    text("""
                    SELECT c.relname || '.' || a.attname
                    FROM pg_class c
                    JOIN pg_namespace n ON n.oid = c.relnamespace
                    JOIN pg_attribute a ON a.attrelid = c.oid
                    WHERE n.nspname = 'public' AND c.relkind IN ('r', 'v')
                      AND c.relname <> 'alembic_version'
                      AND a.attnum > 0 AND NOT a.attisdropped
                      AND col_description(c.oid, a.attnum) IS NULL
                    """)
                ).scalars()
                assert {"analytics_sessions", "analytics_steps", "edge_kinds", "traces"} <= {
                    name for name, _ in relations
                }
                assert [name for name, commented in relations if not commented] == []
                assert list(columns) == []
        finally:
            engine.dispose()
