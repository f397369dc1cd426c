"""studies/outside-the-loop/tilt_holder.py against a real server: every stored version.

The study's tilt-holder must play each strategy's stored versions by id, with one random
stream per world, and play them as ``outside_player.py`` plays the latest one.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

from app.api.app import create_app
from app.api.local_server import serve_in_thread
from app.bench.ingest import build_toy_graph
from app.config import Settings
from app.core.growth.expansion import expand_blend_edge
from app.db.engines import make_engine
from app.db.sessions import session_factory
from app.models import Base
from app.store.artifacts import ArtifactStore
from app.store.graph_persistence import save_graph
from app.store.publications import publish

ROOT = Path(__file__).resolve().parents[2]
TILT_HOLDER = ROOT / "studies/outside-the-loop/tilt_holder.py"
OUTSIDE_PLAYER = ROOT / "studies/judges/outside_player.py"
STRATEGIES = ("baseline", "sr-heuristic", "sr-crowd")


def settings_with_versions(tmp_path: Path) -> tuple[Settings, int]:
    """Each strategy's graph of world 20 published three times: the same toy graph at
    first, then grown by one expansion per strategy more (so the versions differ).
    Returns the settings and the size of the first version."""
    settings = Settings(
        database_url=f"sqlite:///{tmp_path / 'tilt.sqlite3'}", artifact_dir=tmp_path / "data"
    )
    engine = make_engine(settings.resolved_database_url)
    Base.metadata.create_all(engine)
    artifacts = ArtifactStore(settings.resolved_artifact_dir)
    with session_factory(engine)() as session:
        for extra, strategy in enumerate(STRATEGIES, start=1):
            toy = build_toy_graph(session, artifacts, name=f"tt.{strategy}.20")
            first = toy.graph.size_frames
            publish(session, toy.graph_id, toy.graph)
            for _ in range(2):
                for _ in range(extra):
                    expand_blend_edge(
                        toy.graph, toy.bank, toy.dynamics, int(toy.graph.blend_edges()[0])
                    )
                save_graph(session, toy.graph_id, toy.graph, toy.bank, artifacts)
                publish(session, toy.graph_id, toy.graph)
        session.commit()
    engine.dispose()
    return settings, first


def run(script: Path, *args: str) -> list[dict[str, Any]]:
    done = subprocess.run(
        [sys.executable, str(script), *args], capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0, done.stderr
    return [json.loads(line) for line in done.stdout.splitlines()]


def test_every_stored_version_is_played_on_the_world_s_stream(tmp_path: Path) -> None:
    settings, first = settings_with_versions(tmp_path)
    with serve_in_thread(create_app(settings)) as base_url:
        lines = run(TILT_HOLDER, base_url, "0.05", "tt", "20", "--from-frames", str(first + 1))
        latest = run(OUTSIDE_PLAYER, base_url, "0.05", "20", *(f"tt.{s}.20" for s in STRATEGIES))
    assert [(line["strategy"], line["graph"]) for line in lines] == [
        (strategy, f"tt.{strategy}.20") for strategy in STRATEGIES for _ in range(2)
    ]  # the first version of each, below --from-frames, is left out
    assert all(line["world"] == 20 and line["size_frames"] > first for line in lines)
    assert len({line["publication_id"] for line in lines}) == 6
    for line, outside in zip(lines[1::2], latest, strict=True):  # each graph's latest
        assert line["size_frames"] == outside["size_frames"]
        assert (line["mean_error"], line["high_share"], line["steps"]) == (
            outside["mean_error"],
            outside["high_error_fraction"],
            outside["steps"],
        )


def test_the_same_version_of_each_strategy_meets_the_same_stream(tmp_path: Path) -> None:
    """The strategies' first versions are one graph: one stream gives them one figure."""
    settings, first = settings_with_versions(tmp_path)
    with serve_in_thread(create_app(settings)) as base_url:
        lines = run(TILT_HOLDER, base_url, "0.05", "tt", "20")
    firsts = [line for line in lines if line["size_frames"] == first]
    assert [line["strategy"] for line in firsts] == list(STRATEGIES)
    assert len({(line["mean_error"], line["high_share"], line["steps"]) for line in firsts}) == 1
    assert len(lines) == 9 and all(line["steps"] > 0 for line in lines)
