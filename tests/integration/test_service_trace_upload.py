"""A player's trace stored against its publication (app.services.trace_upload): stored
once per idempotency key, and refused, with nothing written, when a step leaves the
publication's edges or the key was used for other steps."""

from __future__ import annotations

import numpy as np
import pytest
from sqlalchemy import func, select
from sqlalchemy.orm import Session

from app.core.graph.clipbank import MemoryClipBank
from app.core.graph.publication import Publication
from app.core.graph.state_graph import StateGraph
from app.core.graph.toy import ToyDynamics
from app.core.players.kinds import PlayerKind
from app.models import Trace, TraceStep
from app.services.trace_upload import load_publication, store_trace
from app.store.artifacts import ArtifactStore
from app.store.graph_catalogue import create_graph
from app.store.graph_persistence import save_graph
from app.store.publications import PublicationNotFound, get_publication, publish
from app.store.traces import IdempotencyConflict, InvalidTrace, get_or_create_player

Toy = tuple[ToyDynamics, StateGraph, MemoryClipBank]


@pytest.fixture
def published(
    session: Session, artifacts: ArtifactStore, toy_graph: Toy
) -> tuple[int, Publication, int]:
    """(publication id, publication, player id) of a saved toy graph published once."""
    _, graph, bank = toy_graph
    graph_id = create_graph(session, name="tank", dynamics="toy", n_controls=3, frames_per_clip=10)
    save_graph(session, graph_id, graph, bank, artifacts)
    publication_id = publish(session, graph_id, graph)
    player, _ = get_or_create_player(session, "ada", PlayerKind.PERSON)
    return publication_id, load_publication(session, publication_id), player


def walk(publication: Publication, controls: list[int]) -> np.ndarray:
    """A trace that follows the publication's edges from its start vertex."""
    steps, vertex = [], publication.start
    for control in controls:
        steps.append((vertex, control))
        vertex = publication.destination(vertex, control)
    return np.array(steps, dtype=np.int64)


def stored(session: Session) -> tuple[int, int]:
    """(traces, trace steps) in the database."""
    traces = session.scalar(select(func.count()).select_from(Trace))
    steps = session.scalar(select(func.count()).select_from(TraceStep))
    return int(traces or 0), int(steps or 0)


def test_a_trace_is_stored_once_and_its_replay_returns_it(
    session: Session, published: tuple[int, Publication, int]
) -> None:
    publication_id, publication, player = published
    steps = walk(publication, [0, 1, 2, 2, 1])
    trace_id, created = store_trace(session, publication, publication_id, player, "k1", steps)
    assert created and stored(session) == (1, 5)
    row = session.get_one(Trace, trace_id)
    assert (row.publication_id, row.player_id, row.n_steps) == (publication_id, player, 5)
    assert row.error == pytest.approx(float(publication.step_errors(steps).sum()))
    again = store_trace(session, publication, publication_id, player, "k1", steps)
    assert again == (trace_id, False) and stored(session) == (1, 5)
    other, created = store_trace(session, publication, publication_id, player, "k2", steps)
    assert created and other != trace_id and stored(session) == (2, 10)


def test_a_key_reused_for_other_steps_is_refused_and_writes_nothing(
    session: Session, published: tuple[int, Publication, int]
) -> None:
    publication_id, publication, player = published
    first = walk(publication, [0, 1, 2])
    store_trace(session, publication, publication_id, player, "k1", first)
    before = stored(session)
    with pytest.raises(IdempotencyConflict, match="idempotency key 'k1' was used for a different"):
        store_trace(session, publication, publication_id, player, "k1", walk(publication, [2, 2]))
    assert stored(session) == before


def test_keys_are_per_player(session: Session, published: tuple[int, Publication, int]) -> None:
    publication_id, publication, ada = published
    bob, _ = get_or_create_player(session, "bob", PlayerKind.PERSON)
    mine = store_trace(session, publication, publication_id, ada, "k1", walk(publication, [0]))
    theirs = store_trace(session, publication, publication_id, bob, "k1", walk(publication, [1]))
    assert mine[1] and theirs[1] and mine[0] != theirs[0]
    assert stored(session) == (2, 2)


def test_a_key_reused_on_another_publication_is_refused(
    session: Session, published: tuple[int, Publication, int], toy_graph: Toy
) -> None:
    publication_id, publication, player = published
    steps = walk(publication, [0, 1])
    store_trace(session, publication, publication_id, player, "k1", steps)
    again = publish(session, get_publication(session, publication_id).graph_id, toy_graph[1])
    with pytest.raises(IdempotencyConflict, match="idempotency key 'k1' was used for a different"):
        store_trace(session, load_publication(session, again), again, player, "k1", steps)
    assert stored(session) == (1, 2)


def test_a_trace_may_start_at_any_vertex(
    session: Session, published: tuple[int, Publication, int]
) -> None:
    """A client splits a long session: its next part starts where the last one ended."""
    publication_id, publication, player = published
    whole = walk(publication, [0, 1, 2, 1, 0, 2])
    assert store_trace(session, publication, publication_id, player, "part.0", whole[:3])[1]
    assert int(whole[3, 0]) != publication.start
    assert store_trace(session, publication, publication_id, player, "part.1", whole[3:])[1]
    assert stored(session) == (2, 6)


@pytest.mark.parametrize(
    ("damage", "fragment"),
    [
        ((2, 1, 7), "step 2 does not follow the edges of publication"),
        ((0, 0, 10_000), "step 0 does not follow the edges of publication"),
        ((3, 0, None), "step 3 does not follow the edges of publication"),
    ],
    ids=["control-out-of-range", "vertex-out-of-range", "off-the-path"],
)
def test_a_step_off_the_edges_is_refused_and_writes_nothing(
    session: Session,
    published: tuple[int, Publication, int],
    damage: tuple[int, int, int | None],
    fragment: str,
) -> None:
    """A control or a vertex out of range, or a vertex that the step before does not
    lead to (None: another vertex of the publication than the one it leads to)."""
    publication_id, publication, player = published
    steps = walk(publication, [0, 1, 2, 0, 1])
    step, column, value = damage
    steps[step, column] = (
        (steps[step, column] + 1) % publication.n_vertices if value is None else value
    )
    with pytest.raises(InvalidTrace) as refused:
        store_trace(session, publication, publication_id, player, "bad", steps)
    assert fragment in str(refused.value)
    assert stored(session) == (0, 0)


def test_a_stray_step_is_named_in_the_details(
    session: Session, published: tuple[int, Publication, int]
) -> None:
    publication_id, publication, player = published
    steps = walk(publication, [0, 1, 2])
    steps[1, 1] = 9
    with pytest.raises(InvalidTrace) as refused:
        store_trace(session, publication, publication_id, player, "bad", steps)
    assert refused.value.details == {"step": 1, "vertex": int(steps[1, 0]), "control": 9}


@pytest.mark.parametrize(
    ("steps", "key", "fragment"),
    [
        (np.zeros((0, 2), dtype=np.int64), "k", "a trace is a non-empty (n, 2) array"),
        (np.zeros((3, 3), dtype=np.int64), "k", "a trace is a non-empty (n, 2) array"),
        (np.zeros((3, 2), dtype=np.float64), "k", "trace steps must be integers"),
        (np.zeros((3, 2), dtype=np.int64), "", "idempotency key must have 1 to 128 characters"),
        (np.zeros((3, 2), dtype=np.int64), "k" * 129, "idempotency key must have 1 to 128"),
    ],
    ids=["empty", "three-columns", "floats", "no-key", "long-key"],
)
def test_a_malformed_upload_is_refused_and_writes_nothing(
    session: Session,
    published: tuple[int, Publication, int],
    steps: np.ndarray,
    key: str,
    fragment: str,
) -> None:
    publication_id, publication, player = published
    with pytest.raises(InvalidTrace) as refused:
        store_trace(session, publication, publication_id, player, key, steps)
    assert fragment in str(refused.value)
    assert stored(session) == (0, 0)


def test_a_trace_of_no_player_is_refused_and_writes_nothing(
    session: Session, published: tuple[int, Publication, int]
) -> None:
    publication_id, publication, player = published
    steps = walk(publication, [1, 1])
    with pytest.raises(InvalidTrace, match=f"no player {player + 1000}"):
        store_trace(session, publication, publication_id, player + 1000, "k", steps)
    assert stored(session) == (0, 0)


def test_the_publication_is_loaded_as_it_was_frozen(
    session: Session, published: tuple[int, Publication, int]
) -> None:
    publication_id, publication, _ = published
    loaded = load_publication(session, publication_id)
    assert (loaded.start, loaded.n_controls) == (publication.start, publication.n_controls)
    np.testing.assert_array_equal(loaded.edge_dst, publication.edge_dst)
    with pytest.raises(PublicationNotFound):
        load_publication(session, publication_id + 1000)
