"""The tilt-holder over HTTP: a player outside srg judging every stored version of a graph.

Why outside srg: sr-crowd's model is learned from the crowd's traces, and srg's bots and
player models are what it could have learned to serve. This policy is in none of them,
so what it meets is a model judged by a policy it never saw (plan.md, "Players"). It
imports nothing of srg, reads publications only and uploads nothing (an upload would
teach sr-crowd), so when it plays changes nothing it meets.

The policy is the tilt holder of ``studies/judges/outside_player.py``, loaded from
that file rather than copied, so the two never differ: it holds a control for a
geometric number of steps (mean 3); when it lets go it takes, with probability 0.7, the
control whose next clip scores most (ties at random), otherwise any control; 30 sessions
of geometric length (mean 60 steps).

For each world seed and each strategy, the graph ``EXPERIMENT.STRATEGY.SEED`` is read
through ``GET /api/graphs/{name}/publications``; each stored version of at least
``--from-frames`` frames is fetched by id and played on a fresh
``np.random.default_rng(seed)``, so the three strategies' versions of a world meet the
same random stream. One JSON line per (world, strategy, publication): its mean error per
step and the share of steps whose error is above THRESHOLD (the experiment's high-error
threshold). Needs numpy only::

    srg serve --port 8765 &   # with the experiment's SRG_VAR_DIR / SRG_DATABASE_URL
    python studies/outside-the-loop/tilt_holder.py http://127.0.0.1:8765 THRESHOLD \\
        outside-the-loop 20,21,22,23,24,25,26,27,28,29 --from-frames 5000
"""

from __future__ import annotations

import argparse
import gzip
import importlib.util
import json
import sys
import urllib.error
import urllib.request
from pathlib import Path
from types import ModuleType
from typing import Any
from urllib.parse import quote

import numpy as np

STRATEGIES = ("baseline", "sr-heuristic", "sr-crowd")
OUTSIDE_PLAYER = Path(__file__).resolve().parents[2] / "studies/judges/outside_player.py"


def outside_player() -> ModuleType:
    """``outside_player.py`` as a module: its ``play`` is the policy (a script, not a package)."""
    spec = importlib.util.spec_from_file_location("outside_player", OUTSIDE_PLAYER)
    if spec is None or spec.loader is None:
        raise SystemExit(f"cannot load the policy from {OUTSIDE_PLAYER}")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def get_json(url: str) -> Any:
    """The JSON body at ``url``, asked gzipped; an HTTP error ends the run naming it."""
    request = urllib.request.Request(url, headers={"Accept-Encoding": "gzip"})
    try:
        with urllib.request.urlopen(request) as answer:
            body = answer.read()
            if answer.headers.get("Content-Encoding") == "gzip":
                body = gzip.decompress(body)
    except urllib.error.HTTPError as exc:
        raise SystemExit(f"GET {url}: {exc.code} {exc.read().decode(errors='replace')}") from None
    return json.loads(body)


def judge(
    policy: ModuleType, url: str, graph: str, seed: int, threshold: float, from_frames: int
) -> list[dict[str, Any]]:
    """The policy's figures on every stored version of ``graph`` from ``from_frames`` on."""
    base = f"{url}/api/graphs/{quote(graph, safe='')}/publications"
    lines = []
    for listed in get_json(base):
        if listed["size_frames"] < from_frames:
            continue
        publication = get_json(f"{base}/{listed['publication_id']}")
        errors = np.array(policy.play(publication, np.random.default_rng(seed)))
        lines.append(
            {
                "graph": graph,
                "publication_id": publication["publication_id"],
                "size_frames": publication["size_frames"],
                "mean_error": float(errors.mean()),
                "high_share": float(np.mean(errors > threshold)),
                "steps": int(errors.size),
            }
        )
    return lines


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("url", help="the server, e.g. http://127.0.0.1:8765")
    parser.add_argument("threshold", type=float, help="the experiment's high-error threshold")
    parser.add_argument("experiment", help="the experiment's name: graphs EXPERIMENT.STRATEGY.SEED")
    parser.add_argument("seeds", help="world seeds, comma-separated: 20,21,22")
    parser.add_argument(
        "--from-frames", type=int, default=0, help="play versions of at least this many frames"
    )
    args = parser.parse_args(argv)
    policy = outside_player()
    url = args.url.rstrip("/")
    for seed in (int(seed) for seed in args.seeds.split(",")):
        for strategy in STRATEGIES:
            graph = f"{args.experiment}.{strategy}.{seed}"
            for line in judge(policy, url, graph, seed, args.threshold, args.from_frames):
                print(json.dumps({"world": seed, "strategy": strategy, **line}), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
