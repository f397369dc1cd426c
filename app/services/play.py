"""Bots playing a graph's latest publication in-process (``srg play``).

Their traces are stored as uploads, exactly as the browser client's are, so growth
learns from them the same way (docs/play.md), under a player of kind ``bot`` so that
analytics tell them from people's.

A bot's sessions are fixed by its seed. A run with no seed chosen draws a fresh one
(:func:`fresh_seed`) and reports it, so two runs store two crowds' play rather than the
same sessions twice, and a run can still be repeated exactly.
"""

from __future__ import annotations

import secrets
import uuid
from dataclasses import dataclass

import numpy as np
from sqlalchemy.orm import Session

from app.config import Settings
from app.core.errors import InvalidInput
from app.core.evaluation.metrics import high_error_fraction, observed_mean_error
from app.core.graph.publication import Publication
from app.core.players.bots import play_sessions
from app.core.players.kinds import BotKind, parse_bot
from app.services.loading import graph_context
from app.store.graph_catalogue import graph_entry
from app.store.publications import latest_publication_id, load_publication
from app.store.traces import bot_player, record_trace


@dataclass
class PlayResult:
    graph: str
    publication_id: int
    #: the bots' seed: ``srg play --seed`` with it plays these very sessions again
    seed: int
    traces: int
    steps: int
    observed_mean_error: float
    high_error_fraction: float
    mean_score_per_step: float


def fresh_seed() -> int:
    """A seed no earlier run chose (one in four billion to repeat), short enough to retype."""
    return secrets.randbelow(2**32)


def play_graph(
    session: Session,
    settings: Settings,
    *,
    name: str | int,
    bot: str = "goal-directed",
    sessions: int = 20,
    mean_steps: int = 90,
    seed: int,
) -> PlayResult:
    """Bots play the latest publication in-process; their traces are stored as uploads."""
    kind = parse_bot(bot)
    if sessions <= 0 or mean_steps < 2:
        raise InvalidInput("sessions must be positive and mean steps at least 2")
    entry = graph_entry(session, name)
    publication_id = latest_publication_id(session, entry.id)
    publication = load_publication(session, publication_id)
    traces = bots_play(
        session,
        publication_id,
        publication,
        kind,
        player=f"bot-{kind.value}",
        key=f"local-{uuid.uuid4().hex}",  # each play is new play data, as each browser's is
        sessions=sessions,
        mean_steps=mean_steps,
        seed=seed,
    )
    threshold = graph_context(entry, settings).threshold
    return PlayResult(
        graph=entry.name,
        publication_id=publication_id,
        seed=seed,
        traces=len(traces),
        steps=sum(len(trace) for trace in traces),
        observed_mean_error=observed_mean_error(traces, publication.edge_err, entry.n_controls),
        high_error_fraction=high_error_fraction(
            traces, publication.edge_err, entry.n_controls, threshold
        ),
        mean_score_per_step=publication.mean_score_per_step(traces),
    )


def bots_play(
    session: Session,
    publication_id: int,
    publication: Publication,
    bot: BotKind,
    *,
    player: str,
    key: str,
    sessions: int,
    mean_steps: int,
    seed: int,
) -> list[np.ndarray]:
    """Bots of one kind play the publication; each session is stored as an upload of the
    bot player ``player`` under the idempotency key ``<key>.<number>``, so playing the
    same key again (a resumed experiment) stores nothing twice. Returns the traces."""
    traces = play_sessions(publication, bot, sessions=sessions, mean_steps=mean_steps, seed=seed)
    player_id = bot_player(session, player)
    for number, trace in enumerate(traces):
        record_trace(
            session, publication_id, player_id, f"{key}.{number}", trace, publication=publication
        )
    return traces
