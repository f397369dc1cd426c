"""The crowd's play, summed as traces are accepted: what growth reads instead of the steps.

:func:`app.store.traces.record_trace` numbers each accepted session in its graph
(:func:`next_session_ordinal`) and adds its steps to the sums (:func:`count_session`)
in the transaction that writes its steps, so a trace is counted exactly when it is
stored. An epoch reads sums bounded by the graph's size (:func:`graph_play_counts`),
however many steps were played (docs/player-models.md, "What growth reads of the traces").
"""

from __future__ import annotations

from typing import Any

import numpy as np
from sqlalchemy import BigInteger, ColumnElement, func, select
from sqlalchemy.dialects import postgresql, sqlite
from sqlalchemy.orm import Session

from app.core.evaluation.prediction import PlayedSessions
from app.core.players.crowd_play import FOLD_BUCKETS, PlayCounts
from app.core.players.kinds import PlayerKind, PlayerSelection
from app.models import GraphSessions, PlayCount, Player, PlayLength, PlayVisit, Trace
from app.models import Publication as PublicationRow


def _upsert(session: Session, model: type[Any], rows: list[dict[str, Any]], keys: list[str]) -> Any:
    """INSERT ``rows``, adding to the counted column of a row whose ``keys`` exist."""
    dialect = session.get_bind().dialect.name
    statement = (postgresql if dialect == "postgresql" else sqlite).insert(model)
    counted = next(column for column in rows[0] if column not in keys)
    return statement.on_conflict_do_update(
        index_elements=keys,
        set_={counted: getattr(model, counted) + getattr(statement.excluded, counted)},
    )


def next_session_ordinal(session: Session, publication_id: int) -> int:
    """The ordinal (0, 1, ...) in its graph of a session about to be stored on the
    publication; on PostgreSQL the graph's counter row stays locked until commit, so
    sessions are numbered in the order of the trace ids allocated after this call."""
    graph_id = session.scalar(
        select(PublicationRow.graph_id).where(PublicationRow.id == publication_id)
    )
    first = [{"graph_id": graph_id, "sessions": 1}]
    counted = _upsert(session, GraphSessions, first, ["graph_id"]).returning(GraphSessions.sessions)
    return int(session.execute(counted, first).scalar_one()) - 1


def count_session(
    session: Session, publication_id: int, kind: PlayerKind, ordinal: int, steps: np.ndarray
) -> None:
    """Add one stored session's (n, 2) steps, played by a player of ``kind``, to the
    publication's sums.

    Rows go in key order, so that concurrent writers lock shared rows in one order.
    """
    steps = np.asarray(steps, dtype=np.int64)
    pairs, taken = np.unique(steps, axis=0, return_counts=True)
    key = {"publication_id": publication_id, "player_kind": kind.value}
    bucket = ordinal % FOLD_BUCKETS
    counts = [
        {**key, "bucket": bucket, "vertex": int(vertex), "control": int(control), "steps": int(n)}
        for (vertex, control), n in zip(pairs, taken, strict=True)
    ]
    session.execute(
        _upsert(session, PlayCount, counts, [*key, "bucket", "vertex", "control"]), counts
    )
    visits = [{**key, "vertex": int(vertex), "sessions": 1} for vertex in np.unique(steps[:, 0])]
    session.execute(_upsert(session, PlayVisit, visits, [*key, "vertex"]), visits)
    length = [{**key, "n_steps": len(steps), "sessions": 1}]
    session.execute(_upsert(session, PlayLength, length, [*key, "n_steps"]), length)


def graph_play_counts(
    session: Session,
    graph_id: int,
    players: PlayerSelection = PlayerSelection.ALL,
    *,
    before: int | None = None,
) -> PlayCounts:
    """Every session ``players`` played on the graph's publications (those older than
    publication ``before`` only, when given), summed over them."""
    counts, lengths = _sums(session, players, _published(graph_id, before), by_publication=False)
    return PlayCounts(*counts.T, *lengths.T)


def publication_play_counts(
    session: Session,
    graph_id: int,
    players: PlayerSelection = PlayerSelection.ALL,
    *,
    before: int | None = None,
) -> list[tuple[int, PlayCounts]]:
    """Each publication of the graph that ``players`` played (by id, oldest first; those
    older than publication ``before`` only, when given) with their sessions' sums."""
    counts, lengths = _sums(session, players, _published(graph_id, before), by_publication=True)
    return [
        (
            int(publication),
            PlayCounts(
                *counts[counts[:, 0] == publication, 1:].T,
                *lengths[lengths[:, 0] == publication, 1:].T,
            ),
        )
        for publication in np.unique(lengths[:, 0])
    ]


def _published(graph_id: int, before: int | None) -> list[ColumnElement[bool]]:
    """The graph's publications older than publication ``before`` (all: None)."""
    chosen = [PublicationRow.graph_id == graph_id]
    if before is not None:
        chosen.append(PublicationRow.id < before)
    return chosen


def _sums(
    session: Session,
    players: PlayerSelection,
    chosen: list[ColumnElement[bool]],
    *,
    by_publication: bool,
) -> tuple[np.ndarray, np.ndarray]:
    """The (publication?, bucket, vertex, control, steps) and (publication?, n_steps,
    sessions) rows of ``players``' sessions on the ``chosen`` publications, summed in the
    database over player kinds, and over publications unless ``by_publication``, as two
    int64 tables."""
    kinds = [kind.value for kind in players.kinds]
    count_key = [PlayCount.publication_id] if by_publication else []
    counts = session.execute(
        select(
            *count_key,
            PlayCount.bucket,
            PlayCount.vertex,
            PlayCount.control,
            func.sum(PlayCount.steps).cast(BigInteger),
        )
        .join(PublicationRow, PublicationRow.id == PlayCount.publication_id)
        .where(*chosen, PlayCount.player_kind.in_(kinds))
        .group_by(*count_key, PlayCount.bucket, PlayCount.vertex, PlayCount.control)
    ).all()
    length_key = [PlayLength.publication_id] if by_publication else []
    lengths = session.execute(
        select(*length_key, PlayLength.n_steps, func.sum(PlayLength.sessions).cast(BigInteger))
        .join(PublicationRow, PublicationRow.id == PlayLength.publication_id)
        .where(*chosen, PlayLength.player_kind.in_(kinds))
        .group_by(*length_key, PlayLength.n_steps)
    ).all()
    return (
        np.array(counts, dtype=np.int64).reshape(len(counts), len(count_key) + 4),
        np.array(lengths, dtype=np.int64).reshape(len(lengths), len(length_key) + 2),
    )


def played_sessions(
    session: Session, publication_id: int, players: PlayerSelection = PlayerSelection.ALL
) -> PlayedSessions:
    """The sessions ``players`` played on the publication, as a prediction is judged
    against them: their sums, and each one's error and length from its trace row."""
    chosen = [PublicationRow.id == publication_id]
    counts, lengths = _sums(session, players, chosen, by_publication=False)
    kinds = [kind.value for kind in players.kinds]
    traces = session.execute(
        select(Trace.error, Trace.n_steps)
        .join(Player, Player.id == Trace.player_id)
        .where(Trace.publication_id == publication_id, Player.kind.in_(kinds))
        .order_by(Trace.id)
    ).all()
    return PlayedSessions(
        PlayCounts(*counts.T, *lengths.T),
        np.array([row.error for row in traces], dtype=np.float64),
        np.array([row.n_steps for row in traces], dtype=np.int64),
    )
