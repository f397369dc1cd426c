"""``srg bench client``: how the browser keeps time while the web client plays.

The browser test (``tests/e2e/test_browser_client.py``) holds the client to what it
decides: every animation-frame callback that ran once a frame was due drew one
(:func:`undrawn_due_frames`), except while it held the last frame for a late clip, and
every late clip had been asked to decode before it was due. How often the browser runs no
callback at all for longer than two frame periods, and so how many due frames it lets
pass, is the browser's and the machine's: a timing figure, which a busy machine makes
worse (9 stalls over 67 ms in 604 frames beside one other job). So is how often a clip
asked ahead is still decoding when it is due (a test run beside other jobs once waited
300 ms for one). Both are measured here, not bounded in a test: a toy publication with an
animation on every edge, served on loopback, played with the keys in headless Chromium for
``seconds`` at a desktop's size.
"""

from __future__ import annotations

import io
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from PIL import Image
from sqlalchemy import Engine
from sqlalchemy.orm import Session

from app.api.app import create_app
from app.api.local_server import serve_in_thread
from app.bench.ingest import ToyGraph, build_toy_graph
from app.config import Settings
from app.core.errors import Unavailable
from app.core.graph.state_graph import EdgeKind
from app.db.engines import make_engine
from app.db.sessions import session_factory
from app.models import Base
from app.render.animation import STRIP_MEDIA_TYPE, encode_strip
from app.store.animations import set_animations
from app.store.artifacts import ArtifactStore
from app.store.publications import publish

if TYPE_CHECKING:
    from playwright.sync_api import Page

#: Debian's chromium, which infra/services.sh installs
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
DESKTOP = {"width": 1280, "height": 800}
#: key held, and for how long (ms): left and right tilts, level between
KEY_PATTERN = [("ArrowLeft", 700), (None, 400), ("ArrowRight", 800), ("ArrowUp", 300)]
#: the client's frame rate
FPS = 30.0
#: the toy graph played: its name and its expansions
TOY_NAME = "e2e-toy"
TOY_EXPANSIONS = 8


@dataclass(frozen=True)
class ClientSite:
    base_url: str
    engine: Engine
    publication_id: int
    #: pixel width of a frame of the stored strips
    frame_width: int


def undrawn_due_frames(
    frames: np.ndarray, ticks: np.ndarray, period: float, waits: np.ndarray | None = None
) -> np.ndarray:
    """The animation-frame callbacks (ms) that ran once the next frame was due and drew
    nothing: the client's gaps, as opposed to the browser's.

    A frame is drawn at the first callback after its boundary, so the next one is due at
    most one ``period`` after the last one drawn; a callback a millisecond past that
    (rounding) that drew no frame left a due frame undrawn. Whether the browser calls
    often does not enter: a stalled browser runs no callback inside its stall. Nor do the
    ``waits`` (rows of from, to; to NaN while it lasts) in which the client held the last
    frame for a clip still decoding: whether that clip had been asked for in time is
    checked on its own (the client's ``lateUnasked``).
    """
    drawn = np.searchsorted(frames, ticks, side="right") - 1
    after = drawn >= 0
    since = ticks[after] - frames[drawn[after]]
    undrawn = ticks[after][since >= period + 1]
    if waits is not None and len(waits):
        ends = np.where(np.isnan(waits[:, 1]), np.inf, waits[:, 1])
        held = (undrawn[:, None] >= waits[:, 0]) & (undrawn[:, None] <= ends)
        undrawn = undrawn[~held.any(axis=1)]
    return np.asarray(undrawn)


def client_waits(stats: dict[str, Any]) -> np.ndarray:
    """The client's holds for late clips as rows of (from, to) ms, to NaN while it lasts."""
    rows = [(start, np.nan if end is None else end) for start, end in stats["waits"]]
    return np.asarray(rows, dtype=float).reshape(-1, 2)


def stall_figures(
    frames: np.ndarray, ticks: np.ndarray, period: float, waits: np.ndarray
) -> dict[str, Any]:
    """What the browser let pass: its stalls (gaps between drawn frames over two periods),
    their share of the gaps, the longest gap and the frames drawn per frame due; and the
    clips still decoding when due, with the time the last frame was held for them."""
    gaps = np.diff(frames)
    stalls = int((gaps > 2 * period).sum())
    due = (frames[-1] - frames[0]) / period
    held = np.nan_to_num(waits[:, 1], nan=float(frames[-1])) - waits[:, 0]
    return {
        "frames_drawn": int(len(frames)),
        "callbacks": int(len(ticks)),
        "stalls": stalls,
        "stall_ms": round(2 * period, 1),
        "stall_share": round(stalls / max(len(gaps), 1), 4),
        "longest_gap_ms": round(float(gaps.max()) if len(gaps) else 0.0, 1),
        "drawn_per_due": round(len(frames) / due, 3) if due > 0 else None,
        "undrawn_due": int(len(undrawn_due_frames(frames, ticks, period, waits))),
        "late_clips": int(len(waits)),
        "late_held_ms": round(float(held.sum()), 1),
    }


def webp_strip(images: np.ndarray) -> bytes:
    """The k frames side by side as one WebP image: how animations were stored before."""
    k, h, w, _ = images.shape
    buffer = io.BytesIO()
    Image.fromarray(images.transpose(1, 0, 2, 3).reshape(h, k * w, 3)).save(buffer, "WEBP")
    return buffer.getvalue()


def render_animations(session: Session, artifacts: ArtifactStore, toy: ToyGraph) -> int:
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
        digests = artifacts.put_many(data, media_type=kind, session=session)
        stored.update(zip(edges, digests, strict=True))
    set_animations(session, toy.graph_id, edges=stored)
    return int(images[0].shape[2])


@contextmanager
def toy_client_site(folder: Path) -> Iterator[ClientSite]:
    """The API and web client on loopback, over a SQLite database in ``folder`` holding a
    published toy graph (:data:`TOY_NAME`) with an animation on every edge."""
    url = f"sqlite:///{folder / 'client.sqlite3'}"
    engine = make_engine(url)
    Base.metadata.create_all(engine)
    artifacts = ArtifactStore(folder / "data")
    with session_factory(engine)() as session:
        toy = build_toy_graph(session, artifacts, name=TOY_NAME, expansions=TOY_EXPANSIONS)
        frame_width = render_animations(session, artifacts, toy)
        publication_id = publish(session, toy.graph_id, toy.graph)
        session.commit()
    settings = Settings(database_url=url, artifact_dir=folder / "data")
    try:
        with serve_in_thread(create_app(settings)) as base_url:
            yield ClientSite(base_url, engine, publication_id, frame_width)
    finally:
        engine.dispose()


def play_with_keys(page: Page) -> None:
    """One round of :data:`KEY_PATTERN`."""
    for key, ms in KEY_PATTERN:
        if key:
            page.keyboard.down(key)
        page.wait_for_timeout(ms)
        if key:
            page.keyboard.up(key)


def bench_client(seconds: float) -> dict[str, Any]:
    """Play the toy site with the keys for ``seconds``; the browser's figures."""
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        raise Unavailable("srg bench client needs playwright (the bench extra)") from None
    if not CHROMIUM.exists():
        raise Unavailable(f"srg bench client needs {CHROMIUM} (apt-get install chromium)")
    with (
        tempfile.TemporaryDirectory(prefix="srg-bench-client-") as folder,
        toy_client_site(Path(folder)) as site,
        sync_playwright() as playwright,
    ):
        browser = playwright.chromium.launch(
            executable_path=str(CHROMIUM), args=CHROMIUM_ARGS, headless=True
        )
        page = browser.new_page(viewport=DESKTOP)  # type: ignore[arg-type]
        page.goto(f"{site.base_url}/?graph={TOY_NAME}")
        page.wait_for_function("window.srgStats && window.srgStats.frames.length > 0")
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            play_with_keys(page)
        stats = page.evaluate(
            "() => ({frames: srgStats.frames, ticks: srgStats.ticks, waits: srgStats.waits})"
        )
        browser.close()
    period = 1000.0 / FPS
    frames, ticks = np.asarray(stats["frames"]), np.asarray(stats["ticks"])
    figures = stall_figures(frames, ticks, period, client_waits(stats))
    return {"seconds": seconds, "fps": FPS, **figures}
