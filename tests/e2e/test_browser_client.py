"""The web client in headless Chromium: gapless play at both sizes, tilt, trace stored.

A desktop window (1280 x 800) plays 20 s with the keys and the stored strips; a phone
(390 x 844, portrait) plays 20 s by tilting (deviceorientation's gamma) and the
half-size strips the server cuts for it; a phone turned to landscape (screen angle 90,
emulated) tilts with beta. Both plays are checked for gaps of the client's making: a
callback of the browser that ran once a frame was due and drew none, other than while the
last frame was held for a late clip, and a late clip that had not been asked to decode
before it was due. How often the browser itself stalls, and how often a clip asked in time
is still decoding, are timing figures of the machine: ``srg bench client`` measures them.

Runs in the normal suite. Without /usr/bin/chromium it skips, except in CI (CI=true),
where a missing browser is a failure: infra installs it there.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pytest
from browser_helpers import require_chromium, trace_steps
from sqlalchemy import select

from app.bench.client import (
    CHROMIUM,
    CHROMIUM_ARGS,
    DESKTOP,
    FPS,
    TOY_NAME,
    ClientSite,
    client_waits,
    play_with_keys,
    toy_client_site,
    undrawn_due_frames,
)
from app.db.sessions import session_factory
from app.models import Trace
from app.store.publications import load_publication

if TYPE_CHECKING:
    from playwright.sync_api import Page

PLAY_SECONDS = 20.0
#: KEY_PATTERN as degrees of tilt towards the screen's right
TILT_PATTERN = [(-30.0, 700), (0.0, 400), (30.0, 800), (0.0, 300)]
PHONE = {"width": 390, "height": 844}


@pytest.fixture
def served(tmp_path: Path) -> Iterator[ClientSite]:
    with toy_client_site(tmp_path) as site:
        yield site


def stored_traces(served: ClientSite, timeout: float = 10.0) -> list[np.ndarray]:
    """The traces on the publication, waiting for the page's last upload to land."""
    deadline = time.monotonic() + timeout
    while True:  # a session a look: one read transaction would keep its first snapshot
        with session_factory(served.engine)() as session:
            ids = session.scalars(
                select(Trace.id).where(Trace.publication_id == served.publication_id)
            ).all()
            if ids or time.monotonic() > deadline:
                return [trace_steps(session, trace_id) for trace_id in ids]
        time.sleep(0.2)


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
    served: ClientSite,
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
        page.goto(f"{served.base_url}/?graph={TOY_NAME}")
        page.wait_for_function("window.srgStats && window.srgStats.frames.length > 0")
        assert page.is_hidden("#loading")  # the first strips are in: no loading sign
        end = time.monotonic() + PLAY_SECONDS
        while time.monotonic() < end:
            play(page)
        if screenshot := os.environ.get("SRG_CLIENT_SCREENSHOT"):
            page.screenshot(path=screenshot.replace(".png", f"-{size}.png"))
        snapshot_at = time.monotonic()
        stats = page.evaluate(
            "() => ({frames: srgStats.frames, ticks: srgStats.ticks, late: srgStats.late,"
            " steps: srgStats.steps, size: srgStats.size, stripWidth: srgStats.stripWidth,"
            " unanimated: srgStats.unanimated, score: srgStats.score, waits: srgStats.waits,"
            " lateUnasked: srgStats.lateUnasked,"
            " shown: document.getElementById('score').textContent})"
        )
        page.goto("about:blank")  # the page is hidden: it uploads its trace on the way out
        between = time.monotonic() - snapshot_at
        # open until the upload has landed: closing the browser could cut it short
        traces = stored_traces(served, timeout=60.0)
        browser.close()

    assert stats["size"] == size and stats["stripWidth"] == served.frame_width * scale
    # the score reads as points: a thousand per unit of the edges' score
    assert int(stats["shown"].replace(",", "")) == math.floor(stats["score"] * 1000 + 0.5)
    frames = np.asarray(stats["frames"])
    assert frames[-1] - frames[0] >= (PLAY_SECONDS - 1) * 1000
    # the client's share of gapless play; the browser's stalls are srg bench client's
    waits = client_waits(stats)
    undrawn = undrawn_due_frames(frames, np.asarray(stats["ticks"]), 1000.0 / FPS, waits)
    assert len(undrawn) == 0, f"frames due at {undrawn} were not drawn"
    assert stats["lateUnasked"] == 0, f"{stats['lateUnasked']} clips were not asked ahead"
    assert stats["unanimated"] == 0  # every edge of the toy graph has its clip
    assert len(traces) == 1
    (trace,) = traces
    # the page plays on between the stats snapshot and leaving: the clips of that time,
    # and the one under way at each end (a loaded machine takes a while to leave)
    assert stats["steps"] <= len(trace) <= stats["steps"] + 2 + between * FPS / 10
    assert stats["steps"] >= 0.9 * PLAY_SECONDS * FPS / 10
    with session_factory(served.engine)() as session:
        publication = load_publication(session, served.publication_id)
    assert publication.follows_edges(trace)
    assert {1, 2} <= set(trace[:, 1].tolist())  # the keys or the tilt went both ways
    seen = trace[: stats["steps"]]
    assert stats["score"] == pytest.approx(
        publication.edge_score[seen[:, 0] * publication.n_controls + seen[:, 1]].sum()
    )


def test_a_phone_in_landscape_tilts_with_beta(served: ClientSite) -> None:
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
        page.goto(f"{served.base_url}/?graph={TOY_NAME}")
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
