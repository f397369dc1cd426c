"""Publications, players, traces and growth epochs in the store."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta, timezone

import numpy as np
import pytest
from sqlalchemy import func, select
from sqlalchemy.orm import Session

from app.core.graph.clipbank import MemoryClipBank
from app.core.graph.publication import freeze
from app.core.graph.state_graph import StateGraph
from app.core.graph.toy import ToyDynamics
from app.core.growth.expansion import expand_blend_edge
from app.core.players.kinds import PlayerKind, PlayerSelection
from app.models import GrowthEpoch, Player, PublicationEdge, Trace, TraceStep
from app.store.animations import set_animations
from app.store.artifacts import ArtifactStore
from app.store.epochs import EpochStatus, finish_epoch, start_epoch
from app.store.graph_catalogue import create_graph
from app.store.graph_persistence import StaleGraph, save_graph
from app.store.publications import (
    PublicationNotFound,
    latest_publication,
    load_publication,
    publish,
)
from app.store.traces import (
    IdempotencyConflict,
    InvalidTrace,
    bot_player,
    get_or_create_player,
    load_traces,
    played_publications,
    player_for_token,
    record_trace,
)

Toy = tuple[ToyDynamics, StateGraph, MemoryClipBank]


@pytest.fixture
def saved(session: Session, artifacts: ArtifactStore, toy_graph: Toy) -> tuple[int, Toy]:
    _, graph, bank = toy_graph
    graph_id = create_graph(session, name="tank", dynamics="toy", n_controls=3, frames_per_clip=10)
    save_graph(session, graph_id, graph, bank, artifacts)
    return graph_id, toy_graph


def walk(graph: StateGraph, controls: list[int]) -> np.ndarray:
    """A trace that follows the graph's edges from the start vertex."""
    steps, vertex = [], graph.start
    for control in controls:
        steps.append((vertex, control))
        vertex = graph.edge_dst[graph.edge_id(vertex, control)]
    return np.array(steps, dtype=np.int64)


def count(session: Session, model: type) -> int:
    return int(session.scalar(select(func.count()).select_from(model)) or 0)


def test_publication_is_a_frozen_copy(
    session: Session, artifacts: ArtifactStore, saved: tuple[int, Toy]
) -> None:
    graph_id, (dynamics, graph, bank) = saved
    animation = artifacts.put_bytes(b"clip", media_type="video/mp4", session=session)
    set_animations(session, graph_id, edges={1: animation})
    assert latest_publication(session, graph_id) is None
    first = publish(session, graph_id, graph)
    expected = freeze(graph)

    expand_blend_edge(graph, bank, dynamics, int(graph.blend_edges()[0]))
    with pytest.raises(StaleGraph):  # unsaved growth is never published
        publish(session, graph_id, graph)
    save_graph(session, graph_id, graph, bank, artifacts)
    second = publish(session, graph_id, graph)

    loaded = load_publication(session, first)
    assert (loaded.n_controls, loaded.start) == (expected.n_controls, expected.start)
    for name in ("edge_dst", "edge_kind", "edge_err", "edge_score"):
        np.testing.assert_array_equal(getattr(loaded, name), getattr(expected, name))
        assert getattr(loaded, name).dtype == getattr(expected, name).dtype
    assert load_publication(session, second).n_vertices == graph.n_vertices
    latest = latest_publication(session, graph_id)
    assert latest is not None and (latest.id, latest.number) == (second, 2)
    stored_animation = session.scalar(
        select(PublicationEdge.animation).where(
            PublicationEdge.publication_id == first,
            PublicationEdge.vertex == 0,
            PublicationEdge.control == 1,
        )
    )
    assert stored_animation == animation
    with pytest.raises(PublicationNotFound):
        load_publication(session, second + 1000)


def test_player_tokens_are_hashed_and_rotated(session: Session) -> None:
    player, token = get_or_create_player(session, "ada", PlayerKind.PERSON)
    assert player_for_token(session, token) == player
    same, new_token = get_or_create_player(session, "ada", PlayerKind.PERSON)
    assert same == player and new_token != token
    assert player_for_token(session, token) is None
    assert player_for_token(session, new_token) == player
    with pytest.raises(ValueError):
        get_or_create_player(session, "eve", "robot")


def test_a_bot_player_is_made_once_and_keeps_its_token(session: Session) -> None:
    bot = bot_player(session, "bot-x")
    assert bot_player(session, "bot-x") == bot and count(session, Player) == 1
    # a player that holds a token (through the API) keeps it when bots reuse its name
    player, token = get_or_create_player(session, "ada", "bot")
    assert bot_player(session, "ada") == player
    assert player_for_token(session, token) == player


def test_traces_round_trip_and_replays_write_nothing(
    session: Session, saved: tuple[int, Toy]
) -> None:
    graph_id, (_, graph, _) = saved
    publication = publish(session, graph_id, graph)
    player, _ = get_or_create_player(session, "bot-1", "bot")
    first, second = walk(graph, [1, 1, 0, 2, 2]), walk(graph, [0, 2])
    trace, created = record_trace(session, publication, player, "k1", first)
    assert created
    assert record_trace(session, publication, player, "k2", second)[1]
    steps_before = count(session, TraceStep)
    assert record_trace(session, publication, player, "k1", first.copy()) == (trace, False)
    assert (count(session, Trace), count(session, TraceStep)) == (2, steps_before)
    with pytest.raises(IdempotencyConflict):
        record_trace(session, publication, player, "k1", second)
    loaded = load_traces(session, [publication])
    assert [t.tolist() for t in loaded] == [first.tolist(), second.tolist()]
    assert load_traces(session, [publication + 1000]) == []


def test_traces_are_read_for_the_players_chosen(session: Session, saved: tuple[int, Toy]) -> None:
    graph_id, (_, graph, _) = saved
    by_person, by_bot = walk(graph, [1, 2]), walk(graph, [0, 0, 1])
    first = publish(session, graph_id, graph)
    person, _ = get_or_create_player(session, "ada", PlayerKind.PERSON)
    record_trace(session, first, person, "k", by_person)
    second = publish(session, graph_id, graph)  # a second publication, bots only
    record_trace(session, second, bot_player(session, "bot-x"), "k", by_bot)

    def steps(players: PlayerSelection) -> list[list[list[int]]]:
        return [t.tolist() for t in load_traces(session, [first, second], players)]

    assert steps(PlayerSelection.ALL) == [by_person.tolist(), by_bot.tolist()]
    assert steps(PlayerSelection.PEOPLE) == [by_person.tolist()]
    assert steps(PlayerSelection.BOTS) == [by_bot.tolist()]
    assert played_publications(session, graph_id) == [first, second]
    assert played_publications(session, graph_id, PlayerSelection.PEOPLE) == [first]
    assert played_publications(session, graph_id, PlayerSelection.BOTS) == [second]


@pytest.mark.parametrize(
    "bad",
    [
        np.array([[0, 0], [999, 1]]),  # does not follow the edge
        np.array([[0, 7]]),  # no such control
        np.array([[-1, 0]]),  # no such vertex
        np.zeros((0, 2), dtype=np.int64),  # empty
        np.array([[0.0, 1.0]]),  # not integers
        np.array([0, 1]),  # not (n, 2)
    ],
)
def test_invalid_trace_writes_nothing(
    session: Session, saved: tuple[int, Toy], bad: np.ndarray
) -> None:
    graph_id, (_, graph, _) = saved
    publication = publish(session, graph_id, graph)
    player, _ = get_or_create_player(session, "bot-2", "bot")
    with pytest.raises(InvalidTrace):
        record_trace(session, publication, player, "bad", bad)
    assert (count(session, Trace), count(session, TraceStep)) == (0, 0)


def test_growth_epochs_are_numbered_per_graph(session: Session, saved: tuple[int, Toy]) -> None:
    graph_id, _ = saved
    first = start_epoch(session, graph_id, "sr-crowd")
    finish_epoch(session, first, expansions=4, relinks=2, size_frames=480)
    second = start_epoch(session, graph_id, "sr-crowd")
    rows = session.scalars(select(GrowthEpoch).order_by(GrowthEpoch.number)).all()
    assert [(r.id, r.number) for r in rows] == [(first, 1), (second, 2)]
    done = rows[0]
    session.refresh(done)
    assert (done.status, done.expansions, done.relinks, done.size_frames) == (
        EpochStatus.FINISHED, 4, 2, 480,
    )  # fmt: skip
    assert done.finished_at is not None and rows[1].status == EpochStatus.RUNNING


def test_timestamps_read_back_aware_in_utc(session: Session, saved: tuple[int, Toy]) -> None:
    """SQLite keeps no time zone: its timestamps came back naive, and the API answered
    them without the offset RFC 3339 requires. On both databases they are UTC instants."""
    graph_id, _ = saved
    epoch_id = start_epoch(session, graph_id, "sr-crowd")
    finish_epoch(session, epoch_id, expansions=1, relinks=0, size_frames=60)
    epoch = session.get_one(GrowthEpoch, epoch_id)
    session.refresh(epoch)  # the database's clock: CURRENT_TIMESTAMP on SQLite, now() here
    assert epoch.started_at.tzinfo is UTC and epoch.finished_at is not None
    assert epoch.finished_at.tzinfo is UTC
    two_hours_east = datetime(2026, 1, 2, 3, 4, 5, tzinfo=timezone(timedelta(hours=2)))
    epoch.finished_at = two_hours_east
    session.flush()
    session.refresh(epoch)
    assert epoch.finished_at == two_hours_east and epoch.finished_at.tzinfo is UTC
