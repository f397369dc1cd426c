"""The web client in headless Chromium: gapless play at both sizes, tilt, trace stored.

A desktop window (1280 x 800) plays 20 s with the keys and the stored strips; a phone
(390 x 844, portrait) plays 20 s by tilting (deviceorientation's gamma) and the
half-size strips the server cuts for it; a phone turned to landscape (screen angle 90,
emulated) tilts with beta. Both plays are checked for gaps.

Runs in the normal suite. Without /usr/bin/chromium it skips, except in CI (CI=true),
where a missing browser is a failure: infra installs it there.
"""

from __future__ import annotations

import io
import math
import os
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pytest
from browser_helpers import (
    CHROMIUM,
    CHROMIUM_ARGS,
    DESKTOP,
    play_with_keys,
    require_chromium,
    trace_steps,
)
from PIL import Image
from sqlalchemy import Engine, select

from app.api.app import create_app
from app.api.local_server import serve_in_thread
from app.bench.ingest import ToyGraph, build_toy_graph
from app.config import Settings
from app.core.graph import EdgeKind
from app.db.engines import make_engine
from app.db.sessions import session_factory
from app.models import Base, Trace
from app.render.animation import STRIP_MEDIA_TYPE, encode_strip
from app.store.animations import set_animations
from app.store.artifacts import ArtifactStore
from app.store.publications import load_publication, publish

if TYPE_CHECKING:
    from playwright.sync_api import Page

PLAY_SECONDS = 20.0
FPS = 30.0
#: KEY_PATTERN as degrees of tilt towards the screen's right
TILT_PATTERN = [(-30.0, 700), (0.0, 400), (30.0, 800), (0.0, 300)]
PHONE = {"width": 390, "height": 844}


@dataclass(frozen=True)
class Served:
    base_url: str
    engine: Engine
    publication_id: int
    #: pixel width of a frame of the stored strips
    frame_width: int


def webp_strip(images: np.ndarray) -> bytes:
    """The k frames side by side as one WebP image: how animations were stored before."""
    k, h, w, _ = images.shape
    buffer = io.BytesIO()
    Image.fromarray(images.transpose(1, 0, 2, 3).reshape(h, k * w, 3)).save(buffer, "WEBP")
    return buffer.getvalue()


def render_animations(session: object, artifacts: ArtifactStore, toy: ToyGraph) -> int:
    """One animation per edge: its clip, or for a BLEND edge its clip blended into the target's.

    Every third edge keeps a WebP image strip, as publications made before VP9 clips
    do, so playback goes back and forth between the two kinds. Returns a frame's width.
    """
    graph, bank, dynamics = toy.graph, toy.bank, toy.dynamics

    def frames(edge: int) -> np.ndarray:
        own = bank.frames(graph.edge_clip[edge])
        if graph.edge_kind[edge] == EdgeKind.SIM:
            return own
        return dynamics.blend(own, bank.frames(graph.edge_clip[graph.edge_target[edge]]))

    images = [dynamics.render(frames(e)) for e in range(graph.n_edges)]
    stored: dict[int, str] = {}
    for kind, encode, edges in [
        ("image/webp", webp_strip, range(0, graph.n_edges, 3)),
        (STRIP_MEDIA_TYPE, encode_strip, [e for e in range(graph.n_edges) if e % 3]),
    ]:
        data = (encode(images[e]) for e in edges)
        digests = artifacts.put_many(data, media_type=kind, session=session)  # type: ignore[arg-type]
        stored.update(zip(edges, digests, strict=True))
    set_animations(session, toy.graph_id, edges=stored)  # type: ignore[arg-type]
    return int(images[0].shape[2])


@pytest.fixture
def served(tmp_path: Path) -> Iterator[Served]:
    url = f"sqlite:///{tmp_path / 'e2e.sqlite3'}"
    engine = make_engine(url)
    Base.metadata.create_all(engine)
    artifacts = ArtifactStore(tmp_path / "data")
    with session_factory(engine)() as session:
        toy = build_toy_graph(session, artifacts, name="e2e-toy", expansions=8)
        frame_width = render_animations(session, artifacts, toy)
        publication_id = publish(session, toy.graph_id, toy.graph)
        session.commit()
    settings = Settings(database_url=url, artifact_dir=tmp_path / "data")
    with serve_in_thread(create_app(settings)) as base_url:
        yield Served(base_url, engine, publication_id, frame_width)
    engine.dispose()


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
        return [trace_steps(session, trace_id) for trace_id in ids]


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


def tilt(page: Page, towards_right: float, angle: int = 0) -> None:
    """A deviceorientation event leaning the device ``towards_right`` degrees.

    At screen angle 0 that is gamma; at 90 (landscape, the device's top to the left) the
    screen's right is the device's bottom, so it is beta.
    """
    beta, gamma = (towards_right, 0.0) if angle == 90 else (60.0, towards_right)
    page.evaluate(
        "([beta, gamma]) => dispatchEvent(new DeviceOrientationEvent('deviceorientation',"
        " {alpha: 0, beta, gamma}))",
        [beta, gamma],
    )


def play_with_tilt(page: Page) -> None:
    for degrees, ms in TILT_PATTERN:
        tilt(page, degrees)
        page.wait_for_timeout(ms)


@pytest.mark.parametrize(
    ("viewport", "size", "scale", "play"),
    [(DESKTOP, "desktop", 1.0, play_with_keys), (PHONE, "phone", 0.5, play_with_tilt)],
    ids=["desktop-keys", "phone-tilt"],
)
def test_the_client_plays_gaplessly_and_uploads_its_trace(
    served: Served,
    viewport: dict[str, int],
    size: str,
    scale: float,
    play: Callable[[Page], None],
) -> None:
    require_chromium()
    from playwright.sync_api import sync_playwright

    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(
            executable_path=str(CHROMIUM), args=CHROMIUM_ARGS, headless=True
        )
        page = browser.new_page(viewport=viewport)  # type: ignore[arg-type]
        page.goto(f"{served.base_url}/?graph=e2e-toy")
        page.wait_for_function("window.srgStats && window.srgStats.frames.length > 0")
        assert page.is_hidden("#loading")  # the first strips are in: no loading sign
        end = time.monotonic() + PLAY_SECONDS
        while time.monotonic() < end:
            play(page)
        if screenshot := os.environ.get("SRG_CLIENT_SCREENSHOT"):
            page.screenshot(path=screenshot.replace(".png", f"-{size}.png"))
        stats = page.evaluate(
            "() => ({frames: srgStats.frames, ticks: srgStats.ticks, late: srgStats.late,"
            " steps: srgStats.steps, size: srgStats.size, stripWidth: srgStats.stripWidth,"
            " unanimated: srgStats.unanimated, score: srgStats.score,"
            " shown: document.getElementById('score').textContent})"
        )
        page.goto("about:blank")  # the page is hidden: it uploads its trace on the way out
        browser.close()

    assert stats["size"] == size and stats["stripWidth"] == served.frame_width * scale
    # the score reads as points: a thousand per unit of the edges' score
    assert int(stats["shown"].replace(",", "")) == math.floor(stats["score"] * 1000 + 0.5)
    frames = np.asarray(stats["frames"])
    period = 1000.0 / FPS
    assert frames[-1] - frames[0] >= (PLAY_SECONDS - 1) * 1000
    assert len(frames) >= 0.9 * (frames[-1] - frames[0]) / period
    assert_no_gaps(frames, np.asarray(stats["ticks"]), period)
    assert stats["late"] == 0 and stats["unanimated"] == 0  # every clip was ready in time
    traces = stored_traces(served)
    assert len(traces) == 1
    (trace,) = traces
    # the page plays on between the stats snapshot and leaving: a clip or two more
    assert stats["steps"] <= len(trace) <= stats["steps"] + 2
    assert stats["steps"] >= 0.9 * PLAY_SECONDS * FPS / 10
    with session_factory(served.engine)() as session:
        publication = load_publication(session, served.publication_id)
    assert publication.follows_edges(trace)
    assert {1, 2} <= set(trace[:, 1].tolist())  # the keys or the tilt went both ways
    seen = trace[: stats["steps"]]
    assert stats["score"] == pytest.approx(
        publication.edge_score[seen[:, 0] * publication.n_controls + seen[:, 1]].sum()
    )


def test_a_phone_in_landscape_tilts_with_beta(served: Served) -> None:
    require_chromium()
    from playwright.sync_api import sync_playwright

    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(
            executable_path=str(CHROMIUM), args=CHROMIUM_ARGS, headless=True
        )
        page = browser.new_page(viewport={"width": 844, "height": 390})
        cdp = page.context.new_cdp_session(page)
        cdp.send(
            "Emulation.setDeviceMetricsOverride",
            {
                "width": 844,
                "height": 390,
                "deviceScaleFactor": 3,
                "mobile": True,
                "screenOrientation": {"type": "landscapePrimary", "angle": 90},
            },
        )
        page.goto(f"{served.base_url}/?graph=e2e-toy")
        page.wait_for_function("window.srgStats && window.srgStats.frames.length > 0")
        assert page.evaluate("screen.orientation.angle") == 90
        assert page.evaluate("srgStats.size") == "phone"  # low as well as narrow is a phone
        for degrees, expected in [(30.0, 2), (-30.0, 1), (0.0, 0)]:
            tilt(page, degrees, angle=90)
            page.wait_for_function(
                f"document.querySelector('.controls .on')?.dataset.control === '{expected}'",
                timeout=2000,
            )
            assert page.evaluate("srgStats.tilt") == degrees
        browser.close()
