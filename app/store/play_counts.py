"""The crowd's play, summed: what growth and analytics read instead of the steps.

:func:`app.store.traces.record_trace` stores a trace uncounted; the first reader of the
graph's sums after it (:func:`count_uploaded`, called by every reader here and in
:mod:`app.store.analytics`) numbers it in its graph and adds its steps to the sums, so a
trace is counted exactly once. An epoch reads sums bounded by the graph's size
(:func:`graph_play_counts`), however many steps were played (docs/player-models.md, "What
growth reads of the traces").
"""

from __future__ import annotations

from typing import Any

import numpy as np
from sqlalchemy import BigInteger, ColumnElement, func, select, text, update
from sqlalchemy.dialects import postgresql, sqlite
from sqlalchemy.orm import Session

from app.core.evaluation.prediction import PlayedSessions
from app.core.players.crowd_play import FOLD_BUCKETS, PlayCounts
from app.core.players.kinds import PlayerSelection
from app.models import GraphSessions, PlayCount, Player, PlayLength, Trace
from app.models import Publication as PublicationRow
from app.store.traces import stored_play


def _upsert(session: Session, model: type[Any], rows: list[dict[str, Any]], keys: list[str]) -> Any:
    """INSERT ``rows``, adding to the counted column of a row whose ``keys`` exist."""
    dialect = session.get_bind().dialect.name
    statement = (postgresql if dialect == "postgresql" else sqlite).insert(model)
    counted = next(column for column in rows[0] if column not in keys)
    return statement.on_conflict_do_update(
        index_elements=keys,
        set_={counted: getattr(model, counted) + getattr(statement.excluded, counted)},
    )


#: the graph's traces not yet counted, in the order they are numbered
UNCOUNTED = text("""
SELECT t.id FROM traces t JOIN publications p ON p.id = t.publication_id
WHERE p.graph_id = :graph_id AND t.ordinal IS NULL
ORDER BY t.id
""")

#: the graph's traces numbered from :first to :end (exclusive), the batch being counted,
#: each with its player's kind
_BATCH = """(
    SELECT t.id, t.publication_id, t.n_steps, t.ordinal, pl.kind
    FROM traces t
    JOIN publications p ON p.id = t.publication_id
    JOIN players pl ON pl.id = t.player_id
    WHERE p.graph_id = :graph_id AND t.ordinal >= :first AND t.ordinal < :end
) b"""

#: the batch's sums added to the stored ones, in SQL that SQLite and PostgreSQL share
#: (``WHERE true`` tells SQLite's parser that ON CONFLICT is not a join's ON)
ADD_BATCH = tuple(
    text(statement)
    for statement in (
        f"""
        INSERT INTO play_counts (publication_id, player_kind, bucket, vertex, control, steps)
        SELECT b.publication_id, b.kind, b.ordinal % {FOLD_BUCKETS}, s.vertex, s.control,
               COUNT(*)
        FROM trace_steps s JOIN {_BATCH} ON b.id = s.trace_id
        WHERE true
        GROUP BY b.publication_id, b.kind, b.ordinal % {FOLD_BUCKETS}, s.vertex, s.control
        ON CONFLICT (publication_id, player_kind, bucket, vertex, control)
        DO UPDATE SET steps = play_counts.steps + excluded.steps
        """,
        f"""
        INSERT INTO play_lengths (publication_id, player_kind, n_steps, sessions)
        SELECT b.publication_id, b.kind, b.n_steps, COUNT(*)
        FROM {_BATCH}
        WHERE true
        GROUP BY b.publication_id, b.kind, b.n_steps
        ON CONFLICT (publication_id, player_kind, n_steps)
        DO UPDATE SET sessions = play_lengths.sessions + excluded.sessions
        """,
        f"""
        INSERT INTO play_visits (publication_id, player_kind, vertex, sessions)
        SELECT v.publication_id, v.kind, v.vertex, COUNT(*)
        FROM (SELECT DISTINCT s.trace_id, b.publication_id, b.kind, s.vertex
              FROM trace_steps s JOIN {_BATCH} ON b.id = s.trace_id) v
        WHERE true
        GROUP BY v.publication_id, v.kind, v.vertex
        ON CONFLICT (publication_id, player_kind, vertex)
        DO UPDATE SET sessions = play_visits.sessions + excluded.sessions
        """,
    )
)

#: one trace numbered (an executemany over the batch)
NUMBERED = text("UPDATE traces SET ordinal = :ordinal WHERE id = :trace")


def count_uploaded(session: Session, graph_id: int) -> int:
    """Number the graph's traces stored since the last count and add their steps to the
    sums; return how many. Every reader of the sums calls it first.

    Uploads store a trace without touching anything shared (docs/player-models.md, "What
    growth reads of the traces"), so that a graph takes uploads as fast as its players
    send them; the count is done here, under the graph's counter row (locked until commit
    on PostgreSQL), numbering the traces in id order after those counted before.
    """
    if session.execute(UNCOUNTED, {"graph_id": graph_id}).first() is None:
        return 0
    taken = [{"graph_id": graph_id, "sessions": 0}]
    counter = _upsert(session, GraphSessions, taken, ["graph_id"]).returning(GraphSessions.sessions)
    first = int(session.execute(counter, taken).scalar_one())
    uncounted = session.scalars(UNCOUNTED, {"graph_id": graph_id}).all()
    if not uncounted:  # counted by another reader while this one waited for the row
        return 0
    end = first + len(uncounted)
    session.execute(
        NUMBERED, [{"trace": trace, "ordinal": first + i} for i, trace in enumerate(uncounted)]
    )
    batch = {"graph_id": graph_id, "first": first, "end": end}
    for statement in ADD_BATCH:
        session.execute(statement, batch)
    session.execute(
        update(GraphSessions).where(GraphSessions.graph_id == graph_id).values(sessions=end)
    )
    return len(uncounted)


def graph_play_counts(
    session: Session,
    graph_id: int,
    players: PlayerSelection = PlayerSelection.ALL,
    *,
    before: int | None = None,
) -> PlayCounts:
    """Every session ``players`` played on the graph's publications (those older than
    publication ``before`` only, when given), summed over them."""
    count_uploaded(session, graph_id)
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
    count_uploaded(session, graph_id)
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
    graph_id = session.scalar(
        select(PublicationRow.graph_id).where(PublicationRow.id == publication_id)
    )
    if graph_id is not None:
        count_uploaded(session, graph_id)
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


#: a publication's summed steps and sessions, every player kind and bucket together
SUMMED = text("""
SELECT (SELECT COALESCE(SUM(steps), 0) FROM play_counts WHERE publication_id = :publication)
         AS steps,
       (SELECT COALESCE(SUM(sessions), 0) FROM play_lengths WHERE publication_id = :publication)
         AS sessions
""")


def sums_equal_steps(session: Session, publication_id: int) -> bool:
    """Whether the publication's sums, once what was uploaded is counted, hold exactly its
    stored step rows and traces: none lost, none counted twice."""
    graph_id = session.scalars(
        select(PublicationRow.graph_id).where(PublicationRow.id == publication_id)
    ).one()
    count_uploaded(session, graph_id)
    traces, steps = stored_play(session, publication_id)
    summed = session.execute(SUMMED, {"publication": publication_id}).one()
    return (int(summed.steps), int(summed.sessions)) == (steps, traces)
