"""A player from outside srg: plays a published graph over HTTP and uploads its traces.

Written against the HTTP API only (no import of srg). Its policy rocks the tank: each
session draws a rhythm (hold one tilt for 2-6 steps, then the other as long) and lets go
(control 0) on 10 % of the steps; it never reads an edge's error, score or kind to
decide. After playing, it reports the error of the edges its sessions took (read from
the same publication), per session, for the measurement only.

usage: player.py URL GRAPH SESSIONS SEED  ->  one JSON line on stdout
"""

import json
import sys
import uuid

import httpx
import numpy as np

url, graph, sessions, seed = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
client = httpx.Client(base_url=url, timeout=60)
publication = client.get(f"/api/graphs/{graph}/publication").raise_for_status().json()
token = client.post("/api/players", json={"kind": "bot"}).raise_for_status().json()["token"]
vertices = publication["vertices"]
errors, blends = [], []
for s in range(sessions):
    rng = np.random.default_rng([seed, s])
    period = int(rng.integers(2, 7))
    first = int(rng.integers(1, 3))
    length = int(rng.integers(40, 81))
    vertex, steps = publication["start"], []
    for t in range(length):
        control = first if (t // period) % 2 == 0 else 3 - first
        if rng.random() < 0.1:
            control = 0
        steps.append((vertex, control))
        vertex = vertices[vertex][control]["dst"]
    client.post(
        "/api/traces",
        headers={"Authorization": f"Bearer {token}"},
        json={
            "publication_id": publication["publication_id"],
            "idempotency_key": str(uuid.uuid4()),
            "steps": steps,
        },
    ).raise_for_status()
    taken = [vertices[v][c] for v, c in steps]
    errors.append(float(np.mean([e["err"] for e in taken])))
    blends.append(float(np.mean([e["kind"] == "blend" for e in taken])))
print(
    json.dumps(
        {
            "graph": graph,
            "publication": publication["number"],
            "size_frames": publication["size_frames"],
            "sessions": sessions,
            "session_errors": errors,
            "mean_error": float(np.mean(errors)),
            "blend_share": float(np.mean(blends)),
        }
    )
)
