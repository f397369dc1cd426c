"""The analytics SQL against hand-counted traces, on SQLite and PostgreSQL."""

from __future__ import annotations

import numpy as np
import pytest
from api_helpers import Published, walk
from sqlalchemy.orm import Session

from app.store.analytics import graph_analytics, session_lengths
from app.store.graphs import GraphNotFound
from app.store.traces import get_or_create_player, record_trace

CONTROLS = ([0, 1, 1, 2], [1, 1], [2, 0, 0, 0, 1, 2, 2, 1, 0, 0])


@pytest.fixture
def traces(session: Session, published: Published) -> list[np.ndarray]:
    player, _ = get_or_create_player(session, "analyst", "bot")
    out = []
    for i, controls in enumerate(CONTROLS):
        steps = np.array(walk(published.publication, controls))
        record_trace(session, published.publication_id, player, f"k{i}", steps)
        out.append(steps)
    return out


def test_reports_match_hand_counts(
    session: Session, published: Published, traces: list[np.ndarray]
) -> None:
    threshold = 0.2
    report = graph_analytics(session, published.name, threshold)
    steps = np.concatenate(traces)
    core = published.publication
    err = core.edge_err[steps[:, 0] * core.n_controls + steps[:, 1]]

    (observed,) = report["observed_error"]
    assert observed["publication_id"] == published.publication_id
    assert (observed["sessions"], observed["steps"]) == (3, len(steps))
    assert observed["mean_error"] == pytest.approx(err.mean())
    assert observed["high_error_fraction"] == pytest.approx((err > threshold).mean())

    visits = {row["vertex"]: row["visits"] for row in report["visit_counts"]}
    vertices, counts = np.unique(steps[:, 0], return_counts=True)
    assert visits == dict(zip(vertices.tolist(), counts.tolist(), strict=True))
    start = next(r for r in report["visit_counts"] if r["vertex"] == core.start)
    assert start["sessions"] == 3

    probabilities = report["control_probabilities"]
    for vertex in vertices.tolist():
        rows = [r for r in probabilities if r["vertex"] == vertex]
        assert sum(r["p"] for r in rows) == pytest.approx(1.0)
        at = steps[steps[:, 0] == vertex]
        for row in rows:
            assert row["n"] == int((at[:, 1] == row["control"]).sum())


def test_session_length_summary(
    session: Session, published: Published, traces: list[np.ndarray]
) -> None:
    lengths = session_lengths(session, published.graph_id)
    assert (lengths.sessions, lengths.min, lengths.max) == (3, 2, 10)
    assert lengths.mean == pytest.approx(16 / 3)
    assert lengths.percentiles == {"p50": 4, "p90": 10, "p99": 10}


def test_a_graph_without_traces_reports_empty(session: Session, published: Published) -> None:
    report = graph_analytics(session, published.name, 0.5)
    assert report["observed_error"] == [] and report["visit_counts"] == []
    assert report["session_lengths"]["sessions"] == 0
    assert report["session_lengths"]["percentiles"] == {}


def test_an_unknown_graph_is_a_lookup_error(session: Session) -> None:
    with pytest.raises(GraphNotFound, match="no graph 'missing'"):
        graph_analytics(session, "missing", 0.5)
