"""A graph is read from one revision, however saves interleave with the read; a stored
graph that breaks an invariant is a named error, never an ``AssertionError``.

The race is forced rather than hoped for: the reader's connection commits another
writer's save just before it reads the clips, between its statements for the vertices
and for the clips. Under PostgreSQL's READ COMMITTED that tore the graph (old vertices,
new clips and edges); SQLite reads one snapshot per transaction.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from database_helpers import migrate, postgres_base_url, postgres_database
from sqlalchemy import Engine, event, update
from sqlalchemy.orm import Session

from app.core.errors import Inconsistent, SrgError
from app.core.graph.clipbank import MemoryClipBank
from app.core.graph.state_graph import GraphInvariantError
from app.core.graph.toy import ToyDynamics
from app.core.growth.expansion import expand_blend_edge, initial_tree
from app.db.engines import make_engine
from app.db.sessions import session_factory
from app.models import Edge
from app.store.artifacts import ArtifactStore
from app.store.graph_catalogue import create_graph, graph_revision
from app.store.graph_persistence import load_graph, require_saved, save_graph

DYNAMICS = ToyDynamics()


@pytest.fixture(params=["sqlite", pytest.param("postgresql", marks=pytest.mark.postgres)])
def engine(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[Engine]:
    """A committed database of its own (the race needs two real transactions)."""
    if request.param == "sqlite":
        url = f"sqlite:///{tmp_path / 'snapshot.sqlite3'}"
        migrate(url)
        urls: Iterator[str] = iter([url])
    else:
        urls = postgres_database(postgres_base_url(), migrated=True)
    for url in urls:
        engine = make_engine(url)
        yield engine
        engine.dispose()


def stored_toy_graph(engine: Engine, artifacts: ArtifactStore) -> int:
    bank = MemoryClipBank()
    graph = initial_tree(DYNAMICS, bank)
    expand_blend_edge(graph, bank, DYNAMICS, int(graph.blend_edges()[0]))
    with session_factory(engine)() as session:
        graph_id = create_graph(session, name="g", dynamics="toy", n_controls=3, frames_per_clip=10)
        save_graph(session, graph_id, graph, bank, artifacts)
        session.commit()
    return graph_id


def test_a_save_committed_in_the_middle_of_a_load_never_tears_the_graph(
    engine: Engine, tmp_path: Path
) -> None:
    artifacts = ArtifactStore(tmp_path / "data")
    graph_id = stored_toy_graph(engine, artifacts)
    sessions = session_factory(engine)
    with sessions() as writer:
        grown, bank = load_graph(writer, graph_id, artifacts, DYNAMICS.shape)
        before = grown.n_vertices
        expand_blend_edge(grown, bank, DYNAMICS, int(grown.blend_edges()[0]))
        after = grown.n_vertices

        with engine.connect() as connection, Session(bind=connection) as reader:
            saved: list[int] = []

            def save_before_the_clips(_conn: Any, _cursor: Any, statement: str, *_: Any) -> None:
                if "FROM clips" in statement and not saved:
                    save_graph(writer, graph_id, grown, bank, artifacts)
                    writer.commit()
                    saved.append(graph_revision(writer, graph_id) or 0)

            event.listen(connection, "before_cursor_execute", save_before_the_clips)
            loaded, _ = load_graph(reader, graph_id, artifacts, DYNAMICS.shape)
            event.remove(connection, "before_cursor_execute", save_before_the_clips)
            assert saved, "the save never ran inside the load"
            # a version the graph had: the one before the save (SQLite's snapshot) or after
            expected = before if engine.dialect.name == "sqlite" else after
            assert (loaded.n_vertices, loaded.n_edges) == (expected, expected * 3)
            loaded.check()
            if engine.dialect.name != "sqlite":
                require_saved(reader, graph_id, loaded)  # remembered at the revision it read


def test_a_stored_graph_that_breaks_an_invariant_is_a_named_error(
    engine: Engine, tmp_path: Path
) -> None:
    artifacts = ArtifactStore(tmp_path / "data")
    graph_id = stored_toy_graph(engine, artifacts)
    with session_factory(engine)() as session:
        session.execute(
            update(Edge).where(Edge.graph_id == graph_id, Edge.vertex == 0).values(dst=10_000)
        )
        with pytest.raises(GraphInvariantError) as raised:
            load_graph(session, graph_id, artifacts, DYNAMICS.shape)
    assert isinstance(raised.value, Inconsistent) and isinstance(raised.value, SrgError)
    assert not isinstance(raised.value, AssertionError)
    assert raised.value.http_status == 500
    assert str(raised.value).startswith(f"graph {graph_id} at revision 1: edge 0 is unfilled")
