"""Uploads of one graph at once, on PostgreSQL: none waits on a row another holds, and the
readers of the sums count every trace exactly once.

The finding: every upload took the graph's counter row (to number its session) and held
it until commit, so one graph's uploads committed one at a time. Now an upload writes
only its own rows, and the first reader of the sums after it numbers and counts it
(``app.store.play_counts.count_uploaded``).
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from database_helpers import postgres_base_url, postgres_database
from sqlalchemy import Engine, text
from sqlalchemy.orm import Session, sessionmaker

from app.bench.ingest import build_toy_graph
from app.core.graph.publication import Publication
from app.core.players.bots import play_sessions
from app.core.players.crowd_play import PlayCounts
from app.core.players.kinds import BotKind
from app.db.engines import make_engine
from app.db.sessions import session_factory
from app.store.artifacts import ArtifactStore
from app.store.play_counts import count_uploaded, graph_play_counts
from app.store.publications import load_publication, publish
from app.store.traces import bot_player, record_trace

pytestmark = pytest.mark.postgres


@dataclass(frozen=True)
class Published:
    sessions: sessionmaker[Session]
    graph_id: int
    publication_id: int
    publication: Publication
    player: int


@pytest.fixture
def published(tmp_path: Path) -> Iterator[Published]:
    """A toy graph published on a database of its own, and a bot player, committed."""
    for url in postgres_database(postgres_base_url(), migrated=True):
        engine: Engine = make_engine(url)
        sessions = session_factory(engine)
        with sessions() as session:
            toy = build_toy_graph(session, ArtifactStore(tmp_path / "data"), name="played")
            publication_id = publish(session, toy.graph_id, toy.graph)
            player = bot_player(session, "bots")
            session.commit()
            publication = load_publication(session, publication_id)
        yield Published(sessions, toy.graph_id, publication_id, publication, player)
        engine.dispose()


def upload(published: Published, key: str, steps: np.ndarray) -> None:
    with published.sessions() as session:
        record_trace(session, published.publication_id, published.player, key, steps)
        session.commit()


def test_an_upload_commits_while_a_reader_holds_the_count(published: Published) -> None:
    first, second = play_sessions(
        published.publication, BotKind.HESITANT, sessions=2, mean_steps=20, seed=0
    )
    upload(published, "first", first)
    with published.sessions() as reader:
        assert count_uploaded(reader, published.graph_id) == 1  # the counter row held
        with published.sessions() as uploader:
            uploader.execute(text("SET LOCAL lock_timeout = '2s'"))
            record_trace(uploader, published.publication_id, published.player, "second", second)
            uploader.commit()
        reader.commit()
    with published.sessions() as reader:
        assert count_uploaded(reader, published.graph_id) == 1
        reader.commit()


def test_uploads_and_readers_at_once_count_every_trace_once(published: Published) -> None:
    traces = play_sessions(
        published.publication, BotKind.HESITANT, sessions=48, mean_steps=30, seed=1
    )
    uploading = threading.Event()
    uploading.set()
    failed: list[BaseException] = []

    def uploader(part: int) -> None:
        try:
            for i in range(part, len(traces), 6):
                upload(published, f"{i}", traces[i])
        except BaseException as exc:  # noqa: BLE001 - handed to the test to judge
            failed.append(exc)

    def reader() -> None:
        try:
            while uploading.is_set():
                with published.sessions() as session:
                    graph_play_counts(session, published.graph_id)
                    session.commit()
        except BaseException as exc:  # noqa: BLE001 - handed to the test to judge
            failed.append(exc)

    uploaders = [threading.Thread(target=uploader, args=(part,)) for part in range(6)]
    readers = [threading.Thread(target=reader) for _ in range(2)]
    for thread in [*uploaders, *readers]:
        thread.start()
    for thread in uploaders:
        thread.join()
    uploading.clear()
    for thread in readers:
        thread.join()
    assert not failed, failed

    with published.sessions() as session:
        counted = graph_play_counts(session, published.graph_id)
        session.commit()
        ordinals = session.execute(text("SELECT id, ordinal FROM traces ORDER BY ordinal")).all()
        steps = session.execute(
            text(
                "SELECT s.trace_id, s.vertex, s.control FROM trace_steps s"
                " JOIN traces t ON t.id = s.trace_id ORDER BY t.ordinal, s.step"
            )
        ).all()
        visits = dict(session.execute(text("SELECT vertex, sessions FROM play_visits")).all())
    assert [row.ordinal for row in ordinals] == list(range(len(traces)))
    by_trace: dict[int, list[tuple[int, int]]] = {row.id: [] for row in ordinals}
    for trace_id, vertex, control in steps:
        by_trace[trace_id].append((vertex, control))
    stored = [np.array(by_trace[row.id], dtype=np.int64) for row in ordinals]
    expected = PlayCounts.of_traces(stored)
    shape = (published.publication.n_vertices, published.publication.n_controls)
    for a, b in zip(counted.fold_counts(60, *shape), expected.fold_counts(60, *shape), strict=True):
        np.testing.assert_array_equal(a, b)
    assert counted.median_length() == expected.median_length()
    assert visits == {
        v: sum(v in set(trace[:, 0].tolist()) for trace in stored)
        for v in {int(v) for trace in stored for v in trace[:, 0]}
    }
