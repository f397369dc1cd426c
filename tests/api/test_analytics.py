"""The analytics SQL against hand-counted traces, on SQLite and PostgreSQL: every figure on
the sessions of the players chosen, and the means with their standard error over sessions."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from api_helpers import Published, walk
from sqlalchemy import text, update
from sqlalchemy.orm import Session

from app.core.evaluation.session_figures import SessionFigure
from app.core.players.kinds import PlayerKind, PlayerSelection
from app.models import Publication as PublicationRow
from app.store.analytics import graph_analytics, session_lengths
from app.store.traces import bot_player, get_or_create_player, record_trace

BOTS = ([0, 1, 1, 2], [1, 1], [2, 0, 0, 0, 1, 2, 2, 1, 0, 0])
PEOPLE = ([2, 2, 2], [0, 1, 2, 0, 1])
THRESHOLD = 0.2


@pytest.fixture
def traces(session: Session, published: Published) -> dict[PlayerSelection, list[np.ndarray]]:
    """Three bot sessions and two people's (of two people), each selection's traces."""
    bot = bot_player(session, "analyst")
    people = [get_or_create_player(session, f"p{i}", PlayerKind.PERSON)[0] for i in range(2)]
    played: dict[PlayerSelection, list[np.ndarray]] = {
        PlayerSelection.BOTS: [],
        PlayerSelection.PEOPLE: [],
    }
    sessions = [(PlayerSelection.BOTS, bot, controls) for controls in BOTS]
    sessions += [(PlayerSelection.PEOPLE, p, c) for p, c in zip(people, PEOPLE, strict=True)]
    for i, (selection, player, controls) in enumerate(sessions):
        steps = np.array(walk(published.publication, controls))
        record_trace(session, published.publication_id, player, f"k{i}", steps)
        played[selection].append(steps)
    played[PlayerSelection.ALL] = played[PlayerSelection.BOTS] + played[PlayerSelection.PEOPLE]
    return played


@pytest.mark.parametrize("players", list(PlayerSelection))
def test_reports_match_hand_counts_of_the_players_chosen(
    session: Session,
    published: Published,
    traces: dict[PlayerSelection, list[np.ndarray]],
    players: PlayerSelection,
) -> None:
    report = graph_analytics(session, published.graph_id, THRESHOLD, players)
    chosen = traces[players]
    steps = np.concatenate(chosen)
    core = published.publication
    err = core.edge_err[steps[:, 0] * core.n_controls + steps[:, 1]]
    assert report["players"] == players.value
    assert report["sessions_by_kind"] == {"person": 2, "bot": 3}  # whoever was chosen

    (observed,) = report["observed_error"]
    assert observed["publication_id"] == published.publication_id
    assert (observed["sessions"], observed["steps"]) == (len(chosen), len(steps))
    assert observed["mean_error"] == pytest.approx(err.mean())
    assert observed["high_error_fraction"] == pytest.approx((err > THRESHOLD).mean())

    visits = {row["vertex"]: row["visits"] for row in report["visit_counts"]}
    vertices, counts = np.unique(steps[:, 0], return_counts=True)
    assert visits == dict(zip(vertices.tolist(), counts.tolist(), strict=True))
    start = next(r for r in report["visit_counts"] if r["vertex"] == core.start)
    assert start["sessions"] == len(chosen)

    probabilities = report["control_probabilities"]
    for vertex in vertices.tolist():
        rows = [r for r in probabilities if r["vertex"] == vertex]
        assert sum(r["p"] for r in rows) == pytest.approx(1.0)
        at = steps[steps[:, 0] == vertex]
        for row in rows:
            assert row["n"] == int((at[:, 1] == row["control"]).sum())
    assert report["session_lengths"]["sessions"] == len(chosen)


def test_the_observed_errors_spread_is_over_sessions(
    session: Session, published: Published, traces: dict[PlayerSelection, list[np.ndarray]]
) -> None:
    (observed,) = graph_analytics(session, published.graph_id, THRESHOLD)["observed_error"]
    core = published.publication

    def per_session(figure: Any) -> SessionFigure:
        totals = [
            figure(core.edge_err[t[:, 0] * core.n_controls + t[:, 1]])
            for t in traces[PlayerSelection.ALL]
        ]
        return SessionFigure.over_sessions(totals, [len(t) for t in traces[PlayerSelection.ALL]])

    mean_error = per_session(np.sum)
    high = per_session(lambda err: np.sum(err > THRESHOLD))
    assert observed["mean_error_relative_se"] == pytest.approx(mean_error.relative_se)
    assert observed["high_error_fraction_relative_se"] == pytest.approx(high.relative_se)


def test_session_length_summary(
    session: Session, published: Published, traces: dict[PlayerSelection, list[np.ndarray]]
) -> None:
    lengths = session_lengths(session, published.graph_id, PlayerSelection.BOTS)
    assert (lengths.sessions, lengths.min, lengths.max) == (3, 2, 10)
    assert lengths.mean == pytest.approx(16 / 3)
    assert lengths.percentiles == {"p50": 4, "p90": 10, "p99": 10}
    assert lengths.mean_relative_se is not None and lengths.mean_relative_se > 0.25
    everyone = session_lengths(session, published.graph_id)
    assert (everyone.sessions, everyone.min, everyone.max) == (5, 2, 10)
    assert everyone.percentiles == {"p50": 4, "p90": 10, "p99": 10}


def test_a_graph_without_traces_of_the_players_chosen_reports_empty(
    session: Session, published: Published
) -> None:
    bot = bot_player(session, "only-bots")
    steps = np.array(walk(published.publication, [1, 2]))
    record_trace(session, published.publication_id, bot, "k", steps)
    report = graph_analytics(session, published.graph_id, 0.5, PlayerSelection.PEOPLE)
    assert report["observed_error"] == [] and report["visit_counts"] == []
    assert report["control_probabilities"] == []
    assert report["session_lengths"]["sessions"] == 0
    assert report["session_lengths"]["percentiles"] == {}
    assert report["sessions_by_kind"] == {"person": 0, "bot": 1}


def test_at_the_publications_own_threshold_the_reports_read_no_step(
    session: Session, published: Published
) -> None:
    """Sums and each session's figures were kept when its trace was stored: with the steps
    gone the reports are the same, and still the hand counts."""
    session.execute(
        update(PublicationRow)
        .where(PublicationRow.id == published.publication_id)
        .values(high_error_threshold=THRESHOLD)
    )
    bot = bot_player(session, "analyst")
    played = [np.array(walk(published.publication, controls)) for controls in BOTS]
    for i, steps in enumerate(played):
        record_trace(session, published.publication_id, bot, f"k{i}", steps)
    kept = graph_analytics(session, published.graph_id, THRESHOLD)
    session.execute(text("DELETE FROM trace_steps"))
    report = graph_analytics(session, published.graph_id, THRESHOLD)
    assert report == kept
    core, steps = published.publication, np.concatenate(played)
    err = core.edge_err[steps[:, 0] * core.n_controls + steps[:, 1]]
    (observed,) = report["observed_error"]
    assert observed["mean_error"] == pytest.approx(err.mean())
    assert observed["high_error_fraction"] == pytest.approx((err > THRESHOLD).mean())
    vertices, counts = np.unique(steps[:, 0], return_counts=True)
    visits = {row["vertex"]: row["visits"] for row in report["visit_counts"]}
    assert visits == dict(zip(vertices.tolist(), counts.tolist(), strict=True))
