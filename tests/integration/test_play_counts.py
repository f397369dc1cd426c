"""The crowd's play summed by its readers: what growth reads, equal to the steps.

Growth reads the sums (``refiner_for``); until they existed it read every step of every
played publication (``load_traces``) and dealt the sessions to folds by their place in
trace-id order. Here both are computed on the same stored traces and must agree exactly:
the cross-validated choice, every candidate's score, the restart rate, the model and the
ranking weights that pick the expansions.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from database_helpers import alembic_config
from sqlalchemy import Connection, Row, select, text
from sqlalchemy.orm import Session

from alembic import command
from app.config import Settings
from app.core.evaluation.prediction import PlayedSessions, prediction_figures
from app.core.growth.kinds import Strategy, parse_strategy
from app.core.growth.refinement import Refiner
from app.core.players.bots import play_sessions
from app.core.players.crowd_models.mixed_error import FittedMixedError, fit_error_share
from app.core.players.crowd_models.shrunk import FittedShrunk, ShrunkFit, shrunk_player_model
from app.core.players.crowd_play import PlayCounts
from app.core.players.kinds import BotKind, PlayerModelKind
from app.core.players.player_models import observed_control_counts
from app.core.players.session_folds import FOLDS, SessionFolds
from app.db.engines import make_engine
from app.db.foreign_keys import foreign_keys_off
from app.models import GraphSessions, Player
from app.services.creation import init_graph
from app.services.graph_cache import graph_cache
from app.services.loading import LoadedGraph, open_graph
from app.services.prediction import crowd_refiner, latest_play_prediction
from app.services.refining import refiner_config, refiner_for
from app.store.graph_persistence import save_graph
from app.store.play_counts import count_uploaded, graph_play_counts, publication_play_counts
from app.store.publications import load_publication, publish
from app.store.traces import (
    InvalidTrace,
    bot_player,
    load_traces,
    played_publications,
    record_trace,
)


def settings_for(db_url: str, tmp_path: Path) -> Settings:
    return Settings().replace(
        database_url=db_url, var_dir=tmp_path / "var", artifact_dir=tmp_path / "artifacts"
    )


def played_graph(session: Session, settings: Settings, model: str) -> LoadedGraph:
    """A toy graph published twice (before and after 8 expansions; the newer one with its
    threshold) and played on both, the older publication's sessions uploaded between the
    newer one's."""
    graph_cache.clear()
    graph_id = int(init_graph(session, settings, name=f"g-{model}", player_model=model)["id"])  # type: ignore[call-overload]
    loaded = open_graph(session, settings, graph_id)
    first = publish(session, graph_id, loaded.graph)
    grower = Refiner(loaded.graph, loaded.bank, loaded.dynamics, Strategy.SR_HEURISTIC)
    grower.grow(expansions=8)
    save_graph(session, graph_id, loaded.graph, loaded.bank, loaded.artifacts)
    second = publish(
        session, graph_id, loaded.graph, threshold=loaded.dynamics.high_error_threshold
    )
    player = bot_player(session, "bots")
    for number, (publication_id, seed) in enumerate(
        [(second, 1), (first, 2), (second, 3), (first, 4)]
    ):
        publication = load_publication(session, publication_id)
        for i, trace in enumerate(
            play_sessions(publication, BotKind.HESITANT, sessions=9, mean_steps=25, seed=seed)
        ):
            record_trace(session, publication_id, player, f"{number}.{i}", trace)
    return loaded


def played_refiner(
    session: Session, db_url: str, tmp_path: Path, model: str
) -> tuple[Settings, LoadedGraph, Refiner]:
    """:func:`played_graph` for ``model``, with its refiner as growth makes it."""
    settings = settings_for(db_url, tmp_path)
    loaded = played_graph(session, settings, model)
    return settings, loaded, refiner_for(session, settings, loaded)


@pytest.mark.parametrize("model", ["shrunk", "eq2"])
def test_growth_from_the_sums_is_growth_from_every_step(
    session: Session, db_url: str, tmp_path: Path, model: str
) -> None:
    settings = settings_for(db_url, tmp_path)
    loaded = played_graph(session, settings, model)
    summed = refiner_for(session, settings, loaded)
    # the path growth took until now: every step, sessions in trace-id order
    strategy = parse_strategy(loaded.entry.strategy)
    config = refiner_config(settings, loaded.dynamics, summed.config.player_model)
    stepped = Refiner(loaded.graph, loaded.bank, loaded.dynamics, strategy, config)
    traces = load_traces(session, played_publications(session, loaded.entry.id))
    stepped.learn(traces)
    assert summed.play.sessions == len(traces) == 36
    assert summed.restart == stepped.restart
    np.testing.assert_array_equal(summed.player_model(), stepped.player_model())
    np.testing.assert_array_equal(summed.weights().weights, stepped.weights().weights)
    if model == "shrunk":
        fit = shrunk_fit(summed)
        assert fit == shrunk_fit(stepped)
        # the chosen candidate's score under folds dealt as they were: session i to i % 5
        dealt = [observed_control_counts(traces[i::FOLDS], *config_shape(loaded)) for i in range(5)]
        folds = SessionFolds(tuple(dealt), np.sum(dealt, axis=0))
        graph = loaded.graph
        score = folds.score(
            lambda counts: shrunk_player_model(
                graph.vertex_descriptors(),
                np.asarray(graph.vertex_control),
                counts,
                fit.radius,
                fit.prior_weight,
                prior=summed.heuristic_model(),
            )
        )
        assert score == fit.cv_scores[(fit.radius, fit.prior_weight)]


def shrunk_fit(refiner: Refiner) -> ShrunkFit:
    """The radius and prior weight ``refiner``'s shrunk model chose."""
    fitted = refiner.crowd_model()
    assert isinstance(fitted, FittedShrunk)
    return fitted.chosen


def config_shape(loaded: LoadedGraph) -> tuple[int, int]:
    return loaded.graph.n_vertices, loaded.graph.n_controls


def test_sums_follow_every_accepted_trace_once(
    session: Session, db_url: str, tmp_path: Path
) -> None:
    """A replayed upload and a refused one add nothing; per publication the sums are
    those of its sessions, numbered in the graph by trace id."""
    settings = settings_for(db_url, tmp_path)
    loaded = played_graph(session, settings, "eq2")
    graph_id = loaded.entry.id
    publications = played_publications(session, graph_id)
    player = session.scalar(select(Player.id).where(Player.name == "bots"))
    assert player is not None
    before = graph_play_counts(session, graph_id)
    replayed = load_traces(session, publications[:1])[0]
    _, created = record_trace(session, publications[0], player, "1.0", replayed)
    assert not created
    with pytest.raises(InvalidTrace):
        record_trace(session, publications[0], player, "stray", np.array([[10**6, 0]]))
    after = graph_play_counts(session, graph_id)
    for a, b in zip(
        before.fold_counts(5, *config_shape(loaded)),
        after.fold_counts(5, *config_shape(loaded)),
        strict=True,
    ):
        np.testing.assert_array_equal(a, b)
    assert session.get(GraphSessions, graph_id).sessions == 36  # type: ignore[union-attr]
    ordered = session.execute(
        text(
            "SELECT t.id, t.publication_id FROM traces t JOIN publications p"
            " ON p.id = t.publication_id WHERE p.graph_id = :g ORDER BY t.id"
        ),
        {"g": graph_id},
    ).all()
    by_id = {row.id: i for i, row in enumerate(ordered)}
    for publication_id, play in publication_play_counts(session, graph_id):
        expected = [
            PlayCounts.of_traces([trace], first=by_id[trace_id])
            for trace_id, trace in zip(
                [row.id for row in ordered if row.publication_id == publication_id],
                load_traces(session, [publication_id]),
                strict=True,
            )
        ]
        shape = config_shape(loaded)
        for a, b in zip(
            play.fold_counts(60, *shape),
            PlayCounts.merged(expected).fold_counts(60, *shape),
            strict=True,
        ):
            np.testing.assert_array_equal(a, b)
        assert play.median_length() == PlayCounts.merged(expected).median_length()


def test_the_migration_sums_the_steps_stored_before_it(empty_db_url: str, tmp_path: Path) -> None:
    """Sums counted by their reader and sums computed from the steps by 0010, 0012 and
    0013 are one, each session's error and ordinal too (the models are at head, so the
    steps are stored at head and the sums dropped under them)."""
    engine = make_engine(empty_db_url)
    tables = ("graph_sessions", "play_counts", "play_lengths", "play_visits")
    errors = text("SELECT id, error, high_error_steps, ordinal FROM traces ORDER BY id")
    try:
        with engine.connect() as connection, foreign_keys_off(connection), connection.begin():
            # the downgrades drop the sums and the thresholds: lost, as asked for
            config = alembic_config(connection, drop_data=True)
            command.upgrade(config, "head")
            with Session(bind=connection) as session:
                played = played_graph(session, settings_for(empty_db_url, tmp_path), "eq2")
                assert count_uploaded(session, played.entry.id) == 36
                session.flush()
            kept = {t: sorted(connection.execute(text(f"SELECT * FROM {t}")).all()) for t in tables}
            assert all(kept.values())
            accepted = connection.execute(errors).all()
            with_threshold = [
                r.high_error_steps for r in accepted if r.high_error_steps is not None
            ]
            assert 0 < len(with_threshold) < len(accepted)  # NULL on the older publication
            # below 0011 the publications' thresholds are gone, so is every high-error count
            for revision in ("0011", "0009"):
                command.downgrade(config, revision)
                command.upgrade(config, "head")
                for t in tables:
                    assert sorted(connection.execute(text(f"SELECT * FROM {t}")).all()) == kept[t]
                summed = connection.execute(errors).all()
                assert [(r.id, r.ordinal) for r in summed] == [(r.id, r.ordinal) for r in accepted]
                assert [r.high_error_steps for r in summed] == (
                    [r.high_error_steps for r in accepted]
                    if revision == "0011"
                    else [None] * len(accepted)
                )
                # SQL adds the steps' errors in its own order: equal up to rounding
                assert [r.error for r in summed] == pytest.approx([r.error for r in accepted])
    finally:
        engine.dispose()


def test_the_latest_publications_prediction_reads_sums_not_steps(
    session: Session, db_url: str, tmp_path: Path
) -> None:
    """``srg analytics``' prediction equals the one computed from the steps in memory, and
    is unchanged when the steps are gone: it reads the sums and each session's error."""
    settings = settings_for(db_url, tmp_path)
    loaded = played_graph(session, settings, "eq2")
    summed = latest_play_prediction(session, settings, loaded.entry.id)
    assert summed is not None
    older, latest_id = played_publications(session, loaded.entry.id)
    latest = load_publication(session, latest_id)
    refiner = crowd_refiner(settings, loaded, PlayerModelKind.EQ2)
    learnt = load_traces(session, [older])
    refiner.learn(learnt)
    stepped = prediction_figures(
        latest,
        refiner.player_model(on=latest),
        refiner.restart,
        PlayedSessions.of_traces(load_traces(session, [latest_id]), latest),
        learned_from=PlayCounts.of_traces(learnt),
    )
    assert summed["sessions_learned_from"] == summed["sessions_predicted"] == 18
    for name, value in stepped.items():
        assert summed[name] == pytest.approx(value, rel=1e-12), name
    session.execute(text("DELETE FROM trace_steps"))
    assert latest_play_prediction(session, settings, loaded.entry.id) == summed


def test_mixed_error_chooses_its_share_on_the_latest_publications_errors(
    session: Session, db_url: str, tmp_path: Path
) -> None:
    _, loaded, refiner = played_refiner(session, db_url, tmp_path, "mixed-error")
    first, second = sorted(played_publications(session, loaded.entry.id))
    assert [play.sessions for _, play in refiner.played] == [18, 18]
    # each publication's sessions are learnt with the graph their players saw
    played = [
        (load_publication(session, i), PlayCounts.of_traces(load_traces(session, [i])))
        for i in (first, second)
    ]
    for (seen, _), (stored, _) in zip(refiner.played, played, strict=True):
        assert seen is not None
        np.testing.assert_array_equal(seen.edge_dst, stored.edge_dst)
    # the sums the store keeps choose as the stored steps themselves would
    fitted = refiner.crowd_model()
    assert isinstance(fitted, FittedMixedError)
    graph = refiner.crowd_graph()
    expected = fit_error_share(
        played,
        lambda counts: fitted.shrunk.of_counts(graph, counts),
        refiner.heuristic_model(),
        loaded.graph.n_vertices,
        refiner.restart,
    )
    assert fitted.share == expected
    assert expected.scores and expected.share == max(expected.scores, key=expected.scores.get)


def test_a_downgrade_counts_the_traces_no_reader_counted(empty_db_url: str, tmp_path: Path) -> None:
    """Below 0013 every trace was counted as it was stored: going down, 0013 counts those
    no reader counted yet as a reader would have."""
    engine = make_engine(empty_db_url)
    tables = ("graph_sessions", "play_counts", "play_lengths", "play_visits")

    def sums(connection: Connection) -> dict[str, list[Row[Any]]]:
        return {t: sorted(connection.execute(text(f"SELECT * FROM {t}")).all()) for t in tables}

    try:
        with engine.connect() as connection, foreign_keys_off(connection), connection.begin():
            config = alembic_config(connection, drop_data=True)  # loses the ordinals
            command.upgrade(config, "head")
            with Session(bind=connection) as session:
                played = played_graph(session, settings_for(empty_db_url, tmp_path), "eq2")
                assert count_uploaded(session, played.entry.id) == 36
                newest = max(played_publications(session, played.entry.id))
                player = session.scalar(select(Player.id).where(Player.name == "bots"))
                assert player is not None
                for i, trace in enumerate(
                    play_sessions(
                        load_publication(session, newest),
                        BotKind.GOAL_DIRECTED,
                        sessions=7,
                        mean_steps=25,
                        seed=5,
                    )
                ):
                    record_trace(session, newest, player, f"late.{i}", trace)
                session.flush()
                with connection.begin_nested() as counting:
                    assert count_uploaded(session, played.entry.id) == 7
                    counted = sums(connection)
                    counting.rollback()
            assert sums(connection) != counted
            command.downgrade(config, "0012")
            assert sums(connection) == counted
    finally:
        engine.dispose()
