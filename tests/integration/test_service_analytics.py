"""What the traces of a graph say (app.services.analytics): the threshold and crowd model
in force, the sessions of the players chosen, how well the model predicted the latest
publication's play, and a warning for every figure that rests on too few sessions
(docs/play.md, "When a figure rests on too few sessions")."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from service_settings import session_settings
from sqlalchemy.orm import Session

from app.config import Settings
from app.core.errors import InvalidInput
from app.core.evaluation.session_figures import MAX_RELATIVE_SE, MIN_SESSIONS
from app.core.graph.toy import ToyDynamics
from app.core.players.bots import play_sessions
from app.core.players.kinds import BotKind, PlayerKind, PlayerSelection
from app.services.analytics import played_graph_analytics
from app.services.catalogue import find_graph
from app.services.creation import init_graph
from app.services.publishing import publish_graph
from app.store.graph_catalogue import GraphNotFound
from app.store.publications import load_publication
from app.store.traces import bot_player, get_or_create_player, record_trace

GRAPH = "tank"
PEOPLE = 3
BOTS = 30
#: a threshold no toy edge's error reaches: every high-error share is 0
ABOVE_EVERY_ERROR = 1e9


@pytest.fixture
def settings(db_url: str, tmp_path: Path) -> Iterator[Settings]:
    yield from session_settings(db_url, tmp_path)


def publish(session: Session, settings: Settings) -> int:
    return publish_graph(session, settings, name=GRAPH, render=False).publication_id


def play(session: Session, publication_id: int, *, people: int, bots: int, key: str) -> None:
    """``people`` sessions of as many people and ``bots`` of one bot on the publication."""
    publication = load_publication(session, publication_id)
    bot = bot_player(session, "bots")
    for i, trace in enumerate(
        play_sessions(publication, BotKind.RANDOM, sessions=people + bots, mean_steps=20, seed=3)
    ):
        player = (
            get_or_create_player(session, f"person-{i}", PlayerKind.PERSON)[0]
            if i < people
            else bot
        )
        record_trace(session, publication_id, player, f"{key}.{i}", trace)


@pytest.fixture
def played(session: Session, settings: Settings) -> int:
    """The toy graph published once and played by 3 people and 30 bot sessions."""
    init_graph(session, settings, name=GRAPH)
    publication_id = publish(session, settings)
    play(session, publication_id, people=PEOPLE, bots=BOTS, key="first")
    return publication_id


def figures(report: dict[str, Any]) -> dict[str, tuple[int, float | None]]:
    """(sessions, relative standard error) of each figure of the report that has a value,
    named as the warnings name them."""
    found: dict[str, tuple[int, float | None]] = {}
    for row in report["observed_error"]:
        found[f"mean error of publication {row['number']}"] = (
            row["sessions"],
            row["mean_error_relative_se"],
        )
        found[f"high-error share of publication {row['number']}"] = (
            row["sessions"],
            row["high_error_fraction_relative_se"],
        )
    lengths = report["session_lengths"]
    if lengths["mean"] is not None:
        found["mean session length"] = (lengths["sessions"], lengths["mean_relative_se"])
    return found


def rule(sessions: int, relative_se: float | None) -> bool:
    """docs/play.md's rule: too few sessions, or a standard error over 25 % of the figure."""
    return sessions < MIN_SESSIONS or (relative_se is not None and relative_se > MAX_RELATIVE_SE)


@pytest.mark.parametrize("model", ["nope", ""])
def test_an_unknown_player_model_is_refused_before_the_graph_is_looked_up(
    session: Session, settings: Settings, model: str
) -> None:
    with pytest.raises(InvalidInput, match=f"unknown player model '{model}'"):
        played_graph_analytics(session, settings, "no-such-graph", player_model=model)


def test_an_unknown_graph_is_not_found(session: Session, settings: Settings) -> None:
    with pytest.raises(GraphNotFound, match="no graph 'no-such-graph'"):
        played_graph_analytics(session, settings, "no-such-graph")


def test_the_threshold_is_the_one_given_else_the_settings_else_the_dynamics(
    session: Session, settings: Settings, played: int
) -> None:
    own = ToyDynamics().high_error_threshold
    assert played_graph_analytics(session, settings, GRAPH)["threshold"] == own
    configured = settings.replace(high_error_threshold=own / 2)
    assert played_graph_analytics(session, configured, GRAPH)["threshold"] == own / 2
    given = played_graph_analytics(session, configured, GRAPH, threshold=ABOVE_EVERY_ERROR)
    assert given["threshold"] == ABOVE_EVERY_ERROR
    assert [row["high_error_fraction"] for row in given["observed_error"]] == [0.0]
    every_step = played_graph_analytics(session, settings, GRAPH, threshold=0.0)
    assert every_step["threshold"] == 0.0  # zero is a threshold given, not "none"


@pytest.mark.parametrize(
    ("players", "sessions"),
    [
        (PlayerSelection.PEOPLE, PEOPLE),
        (PlayerSelection.BOTS, BOTS),
        (PlayerSelection.ALL, PEOPLE + BOTS),
    ],
)
def test_every_figure_is_of_the_players_chosen(
    session: Session, settings: Settings, played: int, players: PlayerSelection, sessions: int
) -> None:
    by_id = str(find_graph(session, GRAPH).id)
    report = played_graph_analytics(session, settings, by_id, players=players)
    assert report["graph"] == by_id and report["players"] == players.value
    assert report["sessions_by_kind"] == {"person": PEOPLE, "bot": BOTS}  # whoever was chosen
    (observed,) = report["observed_error"]
    assert (observed["publication_id"], observed["sessions"]) == (played, sessions)
    assert report["session_lengths"]["sessions"] == sessions


def test_a_figure_of_too_few_sessions_is_warned_of_with_the_sessions_that_would_do(
    session: Session, settings: Settings, played: int
) -> None:
    report = played_graph_analytics(session, settings, GRAPH, players=PlayerSelection.PEOPLE)
    warnings = {w["figure"]: w for w in report["warnings"]}
    assert set(warnings) == {
        "mean error of publication 1",
        "high-error share of publication 1",
        "mean session length",
    }
    for name, warning in warnings.items():
        assert warning["sessions"] == PEOPLE and warning["sessions_needed"] >= MIN_SESSIONS
        assert warning["message"].startswith(
            f"{name} rests on {PEOPLE} sessions, fewer than {MIN_SESSIONS}: even its standard "
            "error is unsure"
        )
        assert warning["message"].endswith(
            f"; about {warning['sessions_needed']} sessions would do"
        )


def test_the_warnings_follow_the_rule_on_enough_sessions_too(
    session: Session, settings: Settings, played: int
) -> None:
    """With 30 bot sessions a figure is warned of exactly when its standard error is over
    25 % of it; a share of 0 that every session agrees on is judged on its count alone."""
    for threshold in (None, ABOVE_EVERY_ERROR):
        report = played_graph_analytics(
            session, settings, GRAPH, players=PlayerSelection.BOTS, threshold=threshold
        )
        warned = {w["figure"]: w for w in report["warnings"]}
        found = figures(report)
        assert {name for name, figure in found.items() if rule(*figure)} == set(warned)
        assert "mean session length" not in warned  # 30 sessions of ~20 steps: well measured
        for name, warning in warned.items():
            assert warning["relative_se"] == found[name][1]
            assert f"its standard error is {warning['relative_se']:.0%} of it" in warning["message"]
        if threshold == ABOVE_EVERY_ERROR:
            assert found["high-error share of publication 1"] == (BOTS, None)  # a share of 0
            assert "high-error share of publication 1" not in warned


def test_without_sessions_there_is_nothing_to_warn_of_or_predict(
    session: Session, settings: Settings
) -> None:
    init_graph(session, settings, name=GRAPH)
    publish(session, settings)
    report = played_graph_analytics(session, settings, GRAPH)
    assert report["observed_error"] == [] and report["session_lengths"]["mean"] is None
    assert report["warnings"] == [] and report["prediction"] is None


def test_the_prediction_of_the_latest_play_is_learnt_from_the_play_before_it(
    session: Session, settings: Settings, played: int
) -> None:
    assert played_graph_analytics(session, settings, GRAPH)["prediction"] is None  # one played
    latest = publish(session, settings)
    play(session, latest, people=PEOPLE, bots=4, key="second")
    report = played_graph_analytics(session, settings, GRAPH)
    prediction = report["prediction"]
    assert prediction["publications_learned_from"] == 1
    assert prediction["sessions_learned_from"] == PEOPLE + BOTS
    assert prediction["sessions_predicted"] == PEOPLE + 4
    assert prediction["player_model"] == settings.growth.player_model  # the graph's own
    chosen = played_graph_analytics(session, settings, GRAPH, player_model="shrunk")
    assert chosen["prediction"]["player_model"] == "shrunk"
    people = played_graph_analytics(session, settings, GRAPH, players=PlayerSelection.PEOPLE)
    assert people["prediction"]["sessions_learned_from"] == PEOPLE
    assert people["prediction"]["sessions_predicted"] == PEOPLE
    judged = [w for w in people["warnings"] if w["figure"].startswith("observed error")]
    assert [w["figure"] for w in judged] == ["observed error the prediction is judged against"]
    assert judged[0]["sessions"] == PEOPLE
