"""Publishing and asking for growth while a graph grows, on SQLite and PostgreSQL.

A real ``srg grow`` runs in a subprocess (its own process and transactions, as an
operator's would), beside the API served on loopback and the CLI run in-process. The
findings: on PostgreSQL publishes beside a grow failed (500s with an AssertionError of
a torn graph, and "graph changed since revision N"); a growth asked of a server beside
a CLI grow was accepted and then failed blaming "an epoch running on the workers" on a
server without any.
"""

from __future__ import annotations

import os
import signal
import subprocess
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import httpx
import pytest
from cli_helpers import SRG, one_line_error, srg
from database_helpers import migrate, postgres_base_url, postgres_database
from sqlalchemy import select, update

from app.api.app import create_app
from app.api.local_server import serve_in_thread
from app.config import Settings
from app.core.graph.state_graph import EdgeKind
from app.db.engines import database_engine, dispose_engines
from app.db.sessions import transaction
from app.models import Edge, GrowthEpoch
from app.models import Publication as PublicationRow
from app.services.creation import init_graph
from app.services.loading import open_graph
from app.store.growth_claims import growth_claim
from app.store.publications import load_publication

pytestmark = pytest.mark.slow

ADMIN = {"Authorization": "Bearer " + "a" * 32}
#: far more than the tests let it grow: the grow is stopped once they are done
LONG_GROW = "2000"
WAIT_S = 120.0


@pytest.fixture(params=["sqlite", pytest.param("postgresql", marks=pytest.mark.postgres)])
def settings(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[Settings]:
    """A committed database of its own holding the toy graph ``g``."""
    if request.param == "sqlite":
        url = f"sqlite:///{tmp_path / 'srg.sqlite3'}"
        migrate(url)
        urls: Iterator[str] = iter([url])
    else:
        urls = postgres_database(postgres_base_url(), migrated=True)
    for url in urls:
        settings = Settings().replace(
            database_url=url,
            artifact_dir=tmp_path / "data",
            admin_token=ADMIN["Authorization"].split()[1],
            growth_renders=False,
            rate_limit_storage="memory://",
        )
        with transaction(settings) as session:
            init_graph(session, settings, name="g", strategy="sr-heuristic")
        yield settings
        dispose_engines()  # before the database is dropped


def environment(settings: Settings) -> dict[str, str]:
    return {
        "SRG_DATABASE_URL": settings.resolved_database_url,
        "SRG_ARTIFACT_DIR": str(settings.resolved_artifact_dir),
        "SRG_GROWTH_RENDERS": "false",
    }


def epochs(settings: Settings) -> list[str]:
    with transaction(settings) as session:
        return list(session.scalars(select(GrowthEpoch.status).order_by(GrowthEpoch.number)))


@contextmanager
def cli_grow(settings: Settings) -> Iterator[subprocess.Popen[str]]:
    """``srg grow g`` in a subprocess, once it has opened its first epoch (it holds the
    graph's growth claim from before then); interrupted (Ctrl-C) on the way out."""
    grow = subprocess.Popen(
        [str(SRG), "grow", "g", "--expansions", LONG_GROW],
        env={**os.environ, **environment(settings)},
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        deadline = time.monotonic() + WAIT_S
        while not epochs(settings):
            assert grow.poll() is None, grow.communicate()[0]
            assert time.monotonic() < deadline, "the grow never opened an epoch"
            time.sleep(0.1)
        yield grow
    finally:
        if grow.poll() is None:
            grow.send_signal(signal.SIGINT)
        grow.communicate(timeout=WAIT_S)


def _grown_since_first_publication(settings: Settings) -> bool:
    with transaction(settings) as session:
        first = session.scalar(
            select(PublicationRow.size_frames).order_by(PublicationRow.number).limit(1)
        )
        return open_graph(session, settings, "g").graph.size_frames > (first or 0)


def test_twenty_publishes_beside_a_running_grow_all_succeed_with_versions_it_had(
    settings: Settings, tmp_path: Path
) -> None:
    var = tmp_path / "var"
    with (
        serve_in_thread(create_app(settings)) as base_url,
        httpx.Client(base_url=base_url, timeout=WAIT_S) as http,
        cli_grow(settings) as grow,
    ):
        for attempt in range(20):
            if attempt == 10:  # the second half beside a graph grown since the first
                deadline = time.monotonic() + WAIT_S
                while not _grown_since_first_publication(settings):
                    assert time.monotonic() < deadline, "the grow never saved an expansion"
                    time.sleep(0.2)
            if attempt % 2:
                reply = http.post("/api/graphs/g/publish", headers=ADMIN)
                assert reply.status_code == 200, reply.text
            else:
                published = srg(var, "publish", "g", "--no-render", **environment(settings))
                assert published.returncode == 0, published.stderr
            assert grow.poll() is None, "the grow ended before the publishes"
    with transaction(settings) as session:
        rows = session.scalars(select(PublicationRow).order_by(PublicationRow.number)).all()
        publications = [(row, load_publication(session, row.id)) for row in rows]
        final = open_graph(session, settings, "g").graph
    assert [row.number for row, _ in publications] == list(range(1, 21))
    sizes = [row.size_frames for row, _ in publications]
    assert sizes == sorted(sizes) and sizes[0] < sizes[-1], "the graph never grew between"
    for row, frozen in publications:
        assert len(frozen.edge_dst) == row.n_edges == row.n_vertices * final.n_controls
        assert all(0 <= dst < row.n_vertices for dst in frozen.edge_dst)
        # an expansion is never undone: each published simulation is still the graph's
        for edge in range(row.n_edges):
            if frozen.edge_kind[edge] == EdgeKind.SIM:
                assert (
                    final.edge_kind[edge] == EdgeKind.SIM
                    and final.edge_dst[edge] == frozen.edge_dst[edge]
                )


def test_a_server_growth_beside_a_cli_grow_is_refused_for_the_true_reason_then_runs(
    settings: Settings,
) -> None:
    with (
        serve_in_thread(create_app(settings)) as base_url,
        httpx.Client(base_url=base_url, timeout=WAIT_S) as http,
    ):
        with cli_grow(settings):
            busy = http.post("/api/graphs/g/grow", json={"expansions": 4}, headers=ADMIN)
            assert busy.status_code == 409, busy.text
            error = busy.json()["error"]
            assert error.startswith("graph 'g' is being grown by another process (an `srg grow`")
            assert "workers" not in error and busy.json()["details"]["poll"]
        # the grow was interrupted mid-epoch: the server's growth finishes that one first
        deadline = time.monotonic() + WAIT_S
        grow = "/api/graphs/g/grow"
        while (reply := http.post(grow, json={"expansions": 4}, headers=ADMIN)).status_code != 202:
            assert reply.status_code == 409 and time.monotonic() < deadline, reply.text
            time.sleep(0.1)  # PostgreSQL ends the killed grow's session a moment after
        poll = reply.json()["poll"]
        while (answer := http.get(poll, headers=ADMIN).json())["running"]:
            assert time.monotonic() < deadline, answer
            time.sleep(0.1)
    assert answer["growth"]["state"] == "finished", str(answer["growth"])
    assert answer["growth"]["reason"] is None
    assert set(epochs(settings)) == {"finished"}


def test_a_cli_grow_beside_a_server_growth_is_one_line_naming_it(
    settings: Settings, tmp_path: Path
) -> None:
    with transaction(settings) as session:
        graph = open_graph(session, settings, "g").entry
    with growth_claim(database_engine(settings), graph.id, graph.name):  # as a server's job
        refused = srg(tmp_path, "grow", "g", "--expansions", "4", **environment(settings))
    one_line_error(refused, "graph 'g' is being grown by another process")
    assert epochs(settings) == []
    grown = srg(tmp_path, "grow", "g", "--expansions", "4", **environment(settings))
    assert grown.returncode == 0, grown.stderr
    assert epochs(settings) == ["finished"]


def test_a_stored_graph_that_breaks_an_invariant_is_one_line_and_a_json_500(
    settings: Settings, tmp_path: Path
) -> None:
    with transaction(settings) as session:
        graph_id = open_graph(session, settings, "g").entry.id
        session.execute(
            update(Edge).where(Edge.graph_id == graph_id, Edge.vertex == 0).values(dst=10_000)
        )
    broken = f"graph {graph_id} at revision 1: edge 0 is unfilled"
    one_line_error(srg(tmp_path, "publish", "g", **environment(settings)), broken)
    with (
        serve_in_thread(create_app(settings)) as base_url,
        httpx.Client(base_url=base_url, timeout=WAIT_S) as http,
    ):
        reply = http.post("/api/graphs/g/publish", headers=ADMIN)
    assert reply.status_code == 500 and reply.json() == {"error": broken, "details": None}
