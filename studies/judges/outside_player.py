"""A player policy that is not in srg: it judges published graphs over the HTTP API.

None of srg's bots or player models contains this policy, so a crowd model is judged
here by players it never saw (docs/experiment.md, "Judges from outside"). It reads only
``GET /api/graphs/{name}/publication``, plays sessions on that version and uploads
nothing (an upload would teach sr-crowd).

The policy, a "tilt holder": it holds a control for a geometric number of steps (mean
``HOLD`` steps); when it lets go it takes, with probability ``GREED``, the control whose
next clip scores most (ties at random) and otherwise any control. Sessions have
geometric lengths of mean ``STEPS``.

    python studies/judges/outside_player.py URL THRESHOLD SEED GRAPH [GRAPH ...]

prints one JSON line per graph: mean error per step and the share of steps above
THRESHOLD (the experiment's high-error threshold). Needs numpy only.
"""

from __future__ import annotations

import gzip
import json
import sys
import urllib.request

import numpy as np

HOLD = 3.0
GREED = 0.7
STEPS = 60
SESSIONS = 30


def publication(url: str, graph: str) -> dict:
    request = urllib.request.Request(f"{url}/api/graphs/{graph}/publication")
    request.add_header("Accept-Encoding", "gzip")
    with urllib.request.urlopen(request) as answer:
        body = answer.read()
        if answer.headers.get("Content-Encoding") == "gzip":
            body = gzip.decompress(body)
    return json.loads(body)


def play(pub: dict, rng: np.random.Generator) -> list[float]:
    edges = pub["vertices"]
    n = pub["n_controls"]
    errors: list[float] = []
    for _ in range(SESSIONS):
        vertex, control, held = pub["start"], 0, 0
        for _ in range(int(rng.geometric(1.0 / STEPS))):
            if held <= 0:
                scores = np.array([edges[vertex][c]["score"] for c in range(n)])
                if rng.random() < GREED:
                    best = np.flatnonzero(scores == scores.max())
                    control = int(rng.choice(best))
                else:
                    control = int(rng.integers(n))
                held = int(rng.geometric(1.0 / HOLD))
            edge = edges[vertex][control]
            errors.append(float(edge["err"]))
            vertex, held = edge["dst"], held - 1
    return errors


def main() -> None:
    url, threshold, seed, graphs = sys.argv[1], float(sys.argv[2]), int(sys.argv[3]), sys.argv[4:]
    for graph in graphs:
        pub = publication(url, graph)
        errors = np.array(play(pub, np.random.default_rng(seed)))
        print(
            json.dumps(
                {
                    "graph": graph,
                    "size_frames": pub["size_frames"],
                    "steps": int(errors.size),
                    "mean_error": float(errors.mean()),
                    "high_error_fraction": float(np.mean(errors > threshold)),
                }
            )
        )


if __name__ == "__main__":
    main()
