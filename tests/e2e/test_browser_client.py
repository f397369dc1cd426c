"""The web client in headless Chromium: 20 s of play with keys, gapless, trace stored.

Runs in the normal suite. Without /usr/bin/chromium it skips, except in CI (CI=true),
where a missing browser is a failure: infra installs it there.
"""

from __future__ import annotations

import os
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from sqlalchemy import Engine, select

from app.api.app import create_app
from app.api.local_server import serve_in_thread
from app.bench.ingest import ToyGraph, build_toy_graph
from app.config import Settings
from app.core.graph import EdgeKind
from app.db import make_engine, session_factory
from app.models import Base, Trace, TraceStep
from app.render.animation import STRIP_MEDIA_TYPE, encode_strip
from app.store.animations import set_animations
from app.store.artifacts import ArtifactStore
from app.store.publications import load_publication, publish

CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]
PLAY_SECONDS = 20.0
FPS = 30.0
#: key held, and for how long (ms): left and right tilts, level between
KEY_PATTERN = [("ArrowLeft", 700), (None, 400), ("ArrowRight", 800), ("ArrowUp", 300)]


@dataclass(frozen=True)
class Served:
    base_url: str
    engine: Engine
    publication_id: int


def render_animations(session: object, artifacts: ArtifactStore, toy: ToyGraph) -> None:
    """One strip per edge: its clip, or for a BLEND edge its clip blended into the target's."""
    graph, bank, dynamics = toy.graph, toy.bank, toy.dynamics

    def frames(edge: int) -> np.ndarray:
        own = bank.frames(graph.edge_clip[edge])
        if graph.edge_kind[edge] == EdgeKind.SIM:
            return own
        return dynamics.blend(own, bank.frames(graph.edge_clip[graph.edge_target[edge]]))

    strips = (encode_strip(dynamics.render(frames(e))) for e in range(graph.n_edges))
    digests = artifacts.put_many(strips, media_type=STRIP_MEDIA_TYPE, session=session)  # type: ignore[arg-type]
    set_animations(session, toy.graph_id, edges=dict(enumerate(digests)))  # type: ignore[arg-type]


@pytest.fixture
def served(tmp_path: Path) -> Iterator[Served]:
    url = f"sqlite:///{tmp_path / 'e2e.sqlite3'}"
    engine = make_engine(url)
    Base.metadata.create_all(engine)
    artifacts = ArtifactStore(tmp_path / "data")
    with session_factory(engine)() as session:
        toy = build_toy_graph(session, artifacts, name="e2e-toy", expansions=8)
        render_animations(session, artifacts, toy)
        publication_id = publish(session, toy.graph_id, toy.graph)
        session.commit()
    settings = Settings(database_url=url, artifact_dir=tmp_path / "data")
    with serve_in_thread(create_app(settings)) as base_url:
        yield Served(base_url, engine, publication_id)
    engine.dispose()


def require_chromium() -> None:
    if CHROMIUM.exists():
        return
    if os.environ.get("CI") == "true":
        pytest.fail(f"{CHROMIUM} is missing in CI (infra/services.sh installs it)")
    pytest.skip(f"{CHROMIUM} is missing (apt-get install -y chromium)")


def stored_traces(served: Served, timeout: float = 10.0) -> list[np.ndarray]:
    """The traces on the publication, waiting for the page's last upload to land."""
    deadline = time.monotonic() + timeout
    with session_factory(served.engine)() as session:
        while True:
            ids = session.scalars(
                select(Trace.id).where(Trace.publication_id == served.publication_id)
            ).all()
            if ids or time.monotonic() > deadline:
                break
            time.sleep(0.2)
        return [
            np.array(
                session.execute(
                    select(TraceStep.vertex, TraceStep.control)
                    .where(TraceStep.trace_id == trace_id)
                    .order_by(TraceStep.step)
                ).all(),
                dtype=np.int64,
            )
            for trace_id in ids
        ]


def assert_no_gaps(frames: np.ndarray, ticks: np.ndarray, period: float) -> None:
    """No gap over two frame periods between drawn frames, except where the browser stalled.

    On a loaded machine the renderer itself may skip animation frames; the client cannot
    draw then. A gap is the client's fault when an animation-frame callback ran inside it
    after the next frame fell due (at most one period after the last one drawn, which was
    drawn at the first callback after its own boundary) and drew nothing; and such
    browser stalls must stay rare.
    """
    gaps = np.diff(frames)
    long = np.flatnonzero(gaps > 2 * period)
    for i in long:
        inside = ticks[(ticks >= frames[i] + period + 1) & (ticks < frames[i + 1])]
        assert len(inside) == 0, f"frames due at {inside} were not drawn"
    assert len(long) <= 0.01 * len(gaps), f"{len(long)} browser stalls over {2 * period:.0f} ms"


def test_the_client_plays_gaplessly_and_uploads_its_trace(served: Served) -> None:
    require_chromium()
    from playwright.sync_api import sync_playwright

    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(
            executable_path=str(CHROMIUM), args=CHROMIUM_ARGS, headless=True
        )
        page = browser.new_page(viewport={"width": 760, "height": 720})
        page.goto(f"{served.base_url}/?graph=e2e-toy")
        page.wait_for_function("window.srgStats && window.srgStats.frames.length > 0")
        end = time.monotonic() + PLAY_SECONDS
        while time.monotonic() < end:
            for key, ms in KEY_PATTERN:
                if key:
                    page.keyboard.down(key)
                page.wait_for_timeout(ms)
                if key:
                    page.keyboard.up(key)
        if screenshot := os.environ.get("SRG_CLIENT_SCREENSHOT"):
            page.screenshot(path=screenshot)
        stats = page.evaluate(
            "() => ({frames: srgStats.frames, ticks: srgStats.ticks, late: srgStats.late,"
            " steps: srgStats.steps,"
            " placeholders: srgStats.placeholders, score: srgStats.score})"
        )
        page.goto("about:blank")  # the page is hidden: it uploads its trace on the way out
        browser.close()

    frames = np.asarray(stats["frames"])
    period = 1000.0 / FPS
    assert frames[-1] - frames[0] >= (PLAY_SECONDS - 1) * 1000
    assert len(frames) >= 0.9 * (frames[-1] - frames[0]) / period
    assert_no_gaps(frames, np.asarray(stats["ticks"]), period)
    assert stats["late"] == 0 and stats["placeholders"] == 0  # every strip was ready in time
    traces = stored_traces(served)
    assert len(traces) == 1
    (trace,) = traces
    # the page plays on between the stats snapshot and leaving: a clip or two more
    assert stats["steps"] <= len(trace) <= stats["steps"] + 2
    assert stats["steps"] >= 0.9 * PLAY_SECONDS * FPS / 10
    with session_factory(served.engine)() as session:
        publication = load_publication(session, served.publication_id)
    assert publication.follows_edges(trace)
    assert {1, 2} <= set(trace[:, 1].tolist())  # the key presses tilted the tank both ways
    seen = trace[: stats["steps"]]
    assert stats["score"] == pytest.approx(
        publication.edge_score[seen[:, 0] * publication.n_controls + seen[:, 1]].sum()
    )
