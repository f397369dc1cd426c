"""Makes docs/images/demo.gif, the README's moving picture, from srg's own clips.

A tiny liquid graph is made and published in a database and artifact directory of its
own, var/demo-gif (``srg init``, ``srg publish``: its clips simulated, rendered and stored
as VP9 like any graph's), then played the way the browser client plays it: the
publication and the clips read over the HTTP API (in process), one control chosen a clip,
the clips of the edges taken decoded and joined at the graph's frame rate. The controls
are fixed, so the same commit makes the same walk.

    python infra/demo_gif.py    # writes docs/images/demo.gif (minutes: it renders)

A second run finds the graph published in var/demo-gif and only makes the GIF again;
remove var/demo-gif to render anew.

docs/images/README.md records the run that made the committed file.
"""

from __future__ import annotations

import argparse
import os
import subprocess
from pathlib import Path

import numpy as np
from fastapi.testclient import TestClient
from PIL import Image

from app.api.app import create_app
from app.config import Settings
from app.render.animation import decode_strip

GRAPH = "demo-gif"
ROOT = Path(__file__).resolve().parents[1]
#: the graph's database and artifacts (var/ is the checkout's own, not committed)
WORK_DIR = ROOT / "var/demo-gif"
#: one control a clip (app/core/liquid/scene.py, TILT_DEGREES: 0 level, 1 and 2 tilted 30 degrees
#: either way), the tilt turned every second clip: the water sloshes across the tank and
#: back all the way (a control held longer on this small graph replays one clip)
CONTROLS = (1, 2, 2, 1, 1, 2, 2, 1, 1, 2, 2, 1)
#: width of the GIF (the clips are 480 x 360): a quarter of the pixels' bytes, still legible
WIDTH = 320
#: colours of the one palette every frame shares (one palette: no flicker between frames)
COLOURS = 96


def played_frames(
    client: TestClient, graph: str, controls: tuple[int, ...]
) -> tuple[list[np.ndarray], float]:
    """The frames a player sees taking ``controls`` from the start, and the frame rate."""
    response = client.get(f"/api/graphs/{graph}/publication")
    response.raise_for_status()
    publication = response.json()
    vertex = publication["start"]
    frames: list[np.ndarray] = []
    for control in controls:
        edge = publication["vertices"][vertex][control]
        clip = client.get(edge["animation"])
        clip.raise_for_status()
        frames.extend(decode_strip(clip.content, publication["frames_per_clip"]))
        vertex = edge["dst"]
    return frames, float(publication["fps"])


def write_gif(frames: list[np.ndarray], fps: float, out: Path) -> None:
    height = round(frames[0].shape[0] * WIDTH / frames[0].shape[1])
    images = [Image.fromarray(f).resize((WIDTH, height), Image.Resampling.LANCZOS) for f in frames]
    # the palette from every 10th frame side by side, so splashes and calm water both get colours
    sample = images[::10]
    mosaic = Image.new("RGB", (WIDTH * len(sample), height))
    for i, image in enumerate(sample):
        mosaic.paste(image, (i * WIDTH, 0))
    palette = mosaic.quantize(colors=COLOURS, method=Image.Quantize.MEDIANCUT)
    paletted = [image.quantize(palette=palette, dither=Image.Dither.NONE) for image in images]
    # GIF delays are whole centiseconds: each frame ends at the centisecond nearest its
    # time, so at 30 fps the delays run 30, 40, 30 ms ... and average 1 / fps
    ends = np.round(np.arange(1, len(images) + 1) * 100 / fps).astype(int)
    delays = (10 * np.diff(ends, prepend=0)).tolist()
    paletted[0].save(
        out, save_all=True, append_images=paletted[1:], duration=delays, loop=0, optimize=True
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs/images/demo.gif")
    out = parser.parse_args().out.resolve()
    WORK_DIR.mkdir(parents=True, exist_ok=True)
    # a database and artifacts of its own, whatever SRG_* or a .env say where it was started
    for name in [name for name in os.environ if name.startswith("SRG_")]:
        del os.environ[name]
    os.environ["SRG_VAR_DIR"] = str(WORK_DIR)
    os.chdir(WORK_DIR)
    made = (WORK_DIR / "srg.sqlite3").exists()
    subprocess.run(["srg", "db", "upgrade"], check=True)  # a graph made by an older commit
    if not made:
        init = ["srg", "init", GRAPH, "--dynamics", "liquid", "--preset", "tiny"]
        subprocess.run(init, check=True)
        subprocess.run(["srg", "publish", GRAPH], check=True)
    with TestClient(create_app(Settings())) as client:
        frames, fps = played_frames(client, GRAPH, CONTROLS)
    write_gif(frames, fps, out)
    print(f"{out}: {len(frames)} frames at {fps:g} fps, {out.stat().st_size:,} bytes")


if __name__ == "__main__":
    main()
