"""The web client on a liquid graph's real clips over a slow network: never a flash.

A liquid graph of the ``tiny`` preset (its initial tree: 4 vertices, 12 edges) is made
and published with its animations, real 480 x 360 VP9 clips of 9-19 KB (about 1.5 min
on 2 cores, once for the module); a toy graph is published beside it without
animations, as `srg demo` publishes its baseline for the bots. Chromium's network is
throttled through the DevTools protocol so that clips arrive late, and a probe samples
the canvas at every animation frame: once the first clip has played, no frame may be
flat (a colour filled over the picture, or a cleared canvas) and "loading clips..."
may never show again.

Slow (the renders); skips without Chromium except in CI, as the toy's browser test.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import pytest
from browser_helpers import require_chromium, trace_steps
from sqlalchemy import Engine, select

from app.api.app import create_app
from app.api.local_server import serve_in_thread
from app.bench.client import CHROMIUM, CHROMIUM_ARGS, DESKTOP, play_with_keys
from app.config import Settings
from app.db.engines import make_engine
from app.db.sessions import session_factory
from app.models import Base, Trace
from app.services.creation import init_graph
from app.services.publishing import publish_graph
from app.store.publications import load_publication

if TYPE_CHECKING:
    from playwright.sync_api import Browser, Page

pytestmark = pytest.mark.slow

LIQUID = "e2e-liquid"
FOR_BOTS = "e2e-for-bots"
#: what the throttled network delivers: 12 KB/s, 150 ms round trips. The 12 clips (180
#: KB) take some 15 s to arrive; the first clip plays after about 8 s, and in the next
#: 20 s 3 to 5 clips are late, 8 to 9 s of waiting in all (old client: 27 late clips,
#: 536 of 1,199 probes flat with "loading clips..." over them)
SLOW_NETWORK = {
    "offline": False,
    "latency": 150,
    "downloadThroughput": 12_000,
    "uploadThroughput": 12_000,
}
PLAY_SECONDS = 20.0

#: Samples the canvas at every animation frame once the first clip has played: a frame
#: whose top three quarters are one colour (all channels within 6 levels on a 16 x 12
#: copy) is flat; "loading clips..." shown is an overlay; the late clip's sign, a wait.
PROBE = """
(() => {
  const probe = {samples: 0, flat: 0, overlay: 0, waiting: 0};
  window.srgProbe = probe;
  const copy = document.createElement("canvas");
  copy.width = 16;
  copy.height = 12;
  const ctx = copy.getContext("2d", {willReadFrequently: true});
  function sample() {
    const screen = document.getElementById("screen");
    if (screen && window.srgStats && srgStats.clips > 0) {
      ctx.clearRect(0, 0, 16, 12);
      ctx.drawImage(screen, 0, 0, 16, 12);
      const pixels = ctx.getImageData(0, 0, 16, 9).data;
      let flat = true;
      for (let c = 0; c < 4 && flat; c++) {
        let lo = 255, hi = 0;
        for (let i = c; i < pixels.length; i += 4) {
          lo = Math.min(lo, pixels[i]);
          hi = Math.max(hi, pixels[i]);
        }
        flat = hi - lo <= 6;
      }
      probe.samples += 1;
      probe.flat += flat;
      probe.overlay += document.getElementById("loading")?.hidden === false;
      probe.waiting += document.getElementById("waiting")?.hidden === false;
    }
    requestAnimationFrame(sample);
  }
  requestAnimationFrame(sample);
})();
"""


@dataclass(frozen=True)
class Served:
    base_url: str
    engine: Engine
    settings: Settings
    publication_id: int


@pytest.fixture(scope="module")
def served(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Served]:
    root = tmp_path_factory.mktemp("liquid")
    url = f"sqlite:///{root / 'e2e.sqlite3'}"
    engine = make_engine(url)
    Base.metadata.create_all(engine)
    settings = Settings(database_url=url, var_dir=root, artifact_dir=root / "data")
    with session_factory(engine)() as session:
        init_graph(session, settings, name=LIQUID, dynamics="liquid", preset="tiny")
        published = publish_graph(session, settings, name=LIQUID)
        init_graph(session, settings, name=FOR_BOTS)
        publish_graph(session, settings, name=FOR_BOTS, render=False)
        session.commit()
    with serve_in_thread(create_app(settings)) as base_url:
        yield Served(base_url, engine, settings, published.publication_id)
    engine.dispose()


@pytest.fixture
def browser() -> Iterator[Browser]:
    require_chromium()
    from playwright.sync_api import sync_playwright

    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(
            executable_path=str(CHROMIUM), args=CHROMIUM_ARGS, headless=True
        )
        yield browser
        browser.close()


def open_game(browser: Browser, served: Served, network: dict[str, Any] | None = None) -> Page:
    """A desktop page playing the liquid graph (the probe installed), on ``network``."""
    page = browser.new_page(viewport=DESKTOP)  # type: ignore[arg-type]
    page.add_init_script(PROBE)
    if network is not None:
        cdp = page.context.new_cdp_session(page)
        cdp.send("Network.enable")
        cdp.send("Network.emulateNetworkConditions", network)
    page.goto(f"{served.base_url}/?graph={LIQUID}")
    page.wait_for_function("window.srgStats && srgStats.clips > 0", timeout=30_000)
    return page


def test_a_late_clip_holds_the_last_frame_over_a_slow_network(
    browser: Browser, served: Served
) -> None:
    page = open_game(browser, served, SLOW_NETWORK)
    end = time.monotonic() + PLAY_SECONDS
    while time.monotonic() < end:
        play_with_keys(page)
    stats = page.evaluate("({...srgStats, frames: srgStats.frames.length, ticks: 0})")
    probe = page.evaluate("srgProbe")
    page.close()

    assert stats["stripWidth"] == 480 and stats["undecodable"] == 0
    assert stats["late"] > 0 and stats["waitedMs"] > 0, "the network was not slow enough"
    assert probe["waiting"] > 0  # the late clips' sign showed meanwhile
    assert probe["samples"] >= PLAY_SECONDS * 30  # the probe ran all along
    assert probe["flat"] == 0, "a flat frame was shown"
    assert probe["overlay"] == 0, '"loading clips..." showed over the game'
    assert stats["clips"] >= PLAY_SECONDS  # it played on, not only waited


def test_the_menu_offers_animated_graphs_and_a_new_game_plays_the_latest_publication(
    browser: Browser, served: Served
) -> None:
    page = open_game(browser, served)
    assert page.eval_on_selector_all("#graph option", "os => os.map(o => o.value)") == [LIQUID]
    page.wait_for_timeout(2000)
    with session_factory(served.engine)() as session:
        newer = publish_graph(session, served.settings, name=LIQUID).publication_id
        session.commit()
    assert page.evaluate("srgStats.publicationId") == served.publication_id  # until a new game
    page.click("#restart")
    page.wait_for_function(f"srgStats.publicationId === {newer}", timeout=10_000)
    steps = page.evaluate("srgStats.steps")
    page.wait_for_function(f"srgStats.steps > {steps} + 3", timeout=10_000)
    page.goto(f"{served.base_url}/?graph={FOR_BOTS}")  # the page uploads its trace on the way
    status = page.wait_for_selector("#status:has-text('cannot play')").text_content()
    traces = stored_traces(served.engine, [served.publication_id, newer])  # before it closes
    page.close()

    assert status is not None and "published without animations" in status
    assert sorted(traces) == [served.publication_id, newer]
    with session_factory(served.engine)() as session:
        for publication_id, steps in traces.items():
            assert len(steps) > 0
            assert load_publication(session, publication_id).follows_edges(steps)


def stored_traces(
    engine: Engine, publications: list[int], timeout: float = 10.0
) -> dict[int, np.ndarray]:
    """The steps played on each of ``publications``, waiting for the uploads to land."""
    deadline = time.monotonic() + timeout
    while True:  # a session a look: one read transaction would keep its first snapshot
        with session_factory(engine)() as session:
            rows = session.execute(
                select(Trace.id, Trace.publication_id).where(Trace.publication_id.in_(publications))
            ).all()
            if len({p for _, p in rows}) == len(publications) or time.monotonic() > deadline:
                return {p: trace_steps(session, trace_id) for trace_id, p in rows}
        time.sleep(0.2)
