"""Players and their traces.

A trace is a played session: rows of (vertex, control) on one publication. Uploads are
validated against that publication before anything is written, and are idempotent on
the client's ``(player, idempotency_key)``: a retried upload returns the trace already
stored and writes nothing, even when two retries race (the unique constraint decides).
A stored trace keeps its error on its publication's frozen edges, and the first reader of
the crowd's sums after it adds its steps to them (:mod:`app.store.play_counts`), so that
analytics never reads the steps again (docs/analytics.md) and an upload writes nothing
that other uploads of the graph wait on.
"""

from __future__ import annotations

import hashlib
import secrets
from collections.abc import Sequence

import numpy as np
from sqlalchemy import ColumnElement, distinct, func, select, true
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from app.core.errors import Conflict, InvalidInput
from app.core.graph.publication import Publication
from app.core.players.kinds import PlayerKind, PlayerSelection
from app.models import Player, Trace, TraceStep
from app.models import Publication as PublicationRow
from app.store._sql import insert_ignoring_duplicates, insert_int_columns
from app.store.publications import load_publication

MAX_KEY_LENGTH = 128


class InvalidTrace(InvalidInput):
    """The trace cannot be stored as given; the message says why."""


class IdempotencyConflict(Conflict):
    """The idempotency key was already used for a different trace."""


def _token_hash(token: str) -> str:
    return hashlib.sha256(token.encode()).hexdigest()


def get_or_create_player(session: Session, name: str, kind: PlayerKind) -> tuple[int, str]:
    """The player named ``name`` (created if new, of ``kind``) and a fresh bearer token.

    Only the token's hash is stored, so an existing player gets a new token and its
    earlier tokens stop working.
    """
    kind = PlayerKind(kind)  # a plain string is refused here, not by the CHECK constraint
    token = secrets.token_urlsafe(32)
    player = session.scalars(select(Player).where(Player.name == name)).one_or_none()
    if player is None:
        player = Player(name=name, kind=kind, token_hash=_token_hash(token))
        session.add(player)
    else:
        player.token_hash = _token_hash(token)
    session.flush()
    return player.id, token


def bot_player(session: Session, name: str) -> int:
    """The id of the bot player ``name``, made if new; its token is never handed out.

    Unlike :func:`get_or_create_player` nothing is rotated, and the insert ignores a
    concurrent one of the same name: parallel experiment runs each record their bots'
    traces under one player without racing on it or locking its row.
    """
    insert_ignoring_duplicates(
        session,
        Player,
        [
            {
                "name": name,
                "kind": PlayerKind.BOT.value,
                "token_hash": _token_hash(secrets.token_urlsafe(32)),
            }
        ],
    )
    return session.scalars(select(Player.id).where(Player.name == name)).one()


def player_for_token(session: Session, token: str) -> int | None:
    return session.scalar(select(Player.id).where(Player.token_hash == _token_hash(token)))


def record_trace(
    session: Session,
    publication_id: int,
    player_id: int,
    idempotency_key: str,
    steps: np.ndarray,
    *,
    publication: Publication | None = None,
) -> tuple[int, bool]:
    """Store a trace; return ``(trace_id, created)``.

    Raises :class:`InvalidTrace` (nothing written) unless every step follows an edge of
    the publication, naming the first that does not (the one check of a trace's steps,
    whoever uploads it); ``publication`` may be passed to skip loading it again.
    :class:`IdempotencyConflict` if the key already names a different trace.
    """
    steps = _validated_steps(steps, idempotency_key)
    if publication is None:
        publication = load_publication(session, publication_id)
    stray = publication.stray_step(steps)
    if stray is not None:
        step, why = stray
        raise InvalidTrace(
            f"step {step} does not follow the edges of publication {publication_id}: {why}",
            details={"step": step, "vertex": int(steps[step, 0]), "control": int(steps[step, 1])},
        )
    existing = _replay(session, publication_id, player_id, idempotency_key, steps)
    if existing is not None:
        return existing, False
    player = session.get(Player, player_id)
    if player is None:
        raise InvalidTrace(f"no player {player_id}")
    errors = publication.step_errors(steps)
    threshold = session.scalar(
        select(PublicationRow.high_error_threshold).where(PublicationRow.id == publication_id)
    )
    try:
        with session.begin_nested():
            trace = Trace(
                publication_id=publication_id,
                player_id=player_id,
                idempotency_key=idempotency_key,
                n_steps=len(steps),
                error=float(errors.sum()),
                high_error_steps=None if threshold is None else int((errors > threshold).sum()),
            )
            session.add(trace)
            session.flush()
    except IntegrityError:
        existing = _replay(session, publication_id, player_id, idempotency_key, steps)
        if existing is None:
            raise
        return existing, False
    insert_int_columns(
        session,
        TraceStep,
        {
            "trace_id": np.full(len(steps), trace.id),
            "step": np.arange(len(steps)),
            "vertex": steps[:, 0],
            "control": steps[:, 1],
        },
    )
    return trace.id, True


def play_summary(session: Session, graph_id: int) -> dict[str, object]:
    """How much the graph was played, over all its publications: traces (one per played
    session), their steps, distinct players, and when the last trace was uploaded
    (ISO 8601, ``None`` before any)."""
    traces, steps, players, last = session.execute(
        select(
            func.count(Trace.id),
            func.coalesce(func.sum(Trace.n_steps), 0),
            func.count(distinct(Trace.player_id)),
            func.max(Trace.created_at),
        )
        .join(PublicationRow, PublicationRow.id == Trace.publication_id)
        .where(PublicationRow.graph_id == graph_id)
    ).one()
    return {
        "traces": int(traces),
        "steps": int(steps),
        "players": int(players),
        "last_upload": None if last is None else last.isoformat(),
    }


def stored_play(session: Session, publication_id: int) -> tuple[int, int]:
    """(traces, step rows) stored for one publication: what an upload really wrote."""
    traces = session.scalar(
        select(func.count()).select_from(Trace).where(Trace.publication_id == publication_id)
    )
    steps = session.scalar(
        select(func.count())
        .select_from(TraceStep)
        .join(Trace, Trace.id == TraceStep.trace_id)
        .where(Trace.publication_id == publication_id)
    )
    return int(traces or 0), int(steps or 0)


def load_traces(
    session: Session,
    publication_ids: Sequence[int],
    players: PlayerSelection = PlayerSelection.ALL,
) -> list[np.ndarray]:
    """Every trace ``players`` played on these publications, oldest first, as (n, 2) int64
    arrays."""
    rows = session.execute(
        select(TraceStep.trace_id, TraceStep.vertex, TraceStep.control)
        .join(Trace, Trace.id == TraceStep.trace_id)
        .where(Trace.publication_id.in_(list(publication_ids)), _played_by(players))
        .order_by(TraceStep.trace_id, TraceStep.step)
    ).all()
    table = np.array(rows, dtype=np.int64).reshape(len(rows), 3)
    starts = np.flatnonzero(np.diff(table[:, 0])) + 1
    return [part[:, 1:].copy() for part in np.split(table, starts)] if len(rows) else []


def _validated_steps(steps: np.ndarray, idempotency_key: str) -> np.ndarray:
    if not 0 < len(idempotency_key) <= MAX_KEY_LENGTH:
        raise InvalidTrace(f"idempotency key must have 1 to {MAX_KEY_LENGTH} characters")
    steps = np.asarray(steps)
    if steps.ndim != 2 or steps.shape[1] != 2 or len(steps) == 0:
        raise InvalidTrace(f"a trace is a non-empty (n, 2) array, got shape {steps.shape}")
    if not np.issubdtype(steps.dtype, np.integer):
        raise InvalidTrace(f"trace steps must be integers, got {steps.dtype}")
    return steps.astype(np.int64)


def _replay(
    session: Session, publication_id: int, player_id: int, key: str, steps: np.ndarray
) -> int | None:
    """The id of the stored trace under this key, if it is this very trace."""
    trace = session.scalars(
        select(Trace).where(Trace.player_id == player_id, Trace.idempotency_key == key)
    ).one_or_none()
    if trace is None:
        return None
    stored = session.execute(
        select(TraceStep.vertex, TraceStep.control)
        .where(TraceStep.trace_id == trace.id)
        .order_by(TraceStep.step)
    ).all()
    if trace.publication_id != publication_id or not np.array_equal(
        np.array(stored, dtype=np.int64).reshape(len(stored), 2), steps
    ):
        raise IdempotencyConflict(f"idempotency key {key!r} was used for a different trace")
    return trace.id


def played_publications(
    session: Session, graph_id: int, players: PlayerSelection = PlayerSelection.ALL
) -> list[int]:
    """Ids of the graph's publications with at least one trace of ``players``, oldest first."""
    played = select(Trace.id).where(Trace.publication_id == PublicationRow.id, _played_by(players))
    return list(
        session.scalars(
            select(PublicationRow.id)
            .where(PublicationRow.graph_id == graph_id)
            .where(played.exists())
            .order_by(PublicationRow.id)
        )
    )


def _played_by(players: PlayerSelection) -> ColumnElement[bool]:
    """The condition on a trace that one of ``players`` played it (true for all)."""
    if players is PlayerSelection.ALL:
        return true()
    kinds = [kind.value for kind in players.kinds]
    return Trace.player_id.in_(select(Player.id).where(Player.kind.in_(kinds)))
