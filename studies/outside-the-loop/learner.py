"""A crowd that drifts: a player outside srg that learns as it plays, over HTTP only.

plan.md, section 5, "A crowd that drifts". Written against the HTTP API alone (numpy and
the standard library; it imports nothing of srg). Unlike the tilt-holder it uploads what
it plays, so sr-crowd learns from it, and its own policy changes round after round.

The policy, per session:

- **Hold length.** It draws a hold length h from {1, 2, 4, 8} steps by a softmax over
  the mean score per step each length earned it in its own earlier sessions, each over
  the best of the four (so the best length weighs 1, the others their share of it), at
  temperature ``1 / (1 + round)`` (round 0 is the first): P(h) proportional to
  ``exp(mean_score(h) / best / T)``. A length never tried yet counts as the best mean
  seen so far (an optimistic start, so that every length gets tried); before any session
  every length is untried, so the first round draws the four uniformly.
- **Within the session.** At the start vertex it takes the control whose next clip scores
  most (the edge's ``score``; ties at random), holds it for h steps, then chooses again
  the same way at the vertex it has reached, and so on to the session's end.
- **Session length.** Geometric with mean 60, at least 2 steps (as srg's bots draw theirs:
  ``max(geometric(1/60), 2)``).
- It never reads an edge's ``err`` or ``kind`` to decide: it reads them only to report.

**Why the means are taken over the best** (deviations.md, 2026-12-07): read in the unit
the API serves (the liquid's volume in the target, at most about 0.033 a step), the
logits of the plan's literal rule differ by at most 0.033 x (1 + round), so the hold
probabilities stayed at 0.250 to three decimals in every round of a trial: a player that
does not drift. Over the best, the rule means the same whatever the score's unit, as
srg's own bots scale their values per vertex to [0, 1] before their softmax.

**What it learns from, and when.** Its memory is, per hold length, the total score its
sessions of that length earned and their total steps. The memory a round plays by is the
sum over the *earlier* rounds; every session of the round (on all the graphs it is given:
one player playing three versions of the game, sr-crowd's as much as baseline's and
sr-heuristic's) is added to it once the round is over. Within a round the policy is
therefore the same on every graph, so the three strategies' versions are met by the same
player; the policy drifts from round to round. Run it once per round with all the round's
graphs.

**State.** A JSON file (created if absent): the player registered for it (one
``POST /api/players`` per state file, its token kept there) and, per round played, the
score and steps per hold length that round added. A round played again (a rerun after a
stop) replaces its own entry and plays by the rounds before it only, so a rerun neither
counts a round twice nor changes the policy. Its traces are uploaded under idempotency
keys made of round, publication, seed, graph position and session, so a rerun on the same
publication stores nothing twice.

Per graph it fetches the latest publication (``GET /api/graphs/{name}/publication``),
plays ``--sessions`` sessions (30) on ``np.random.default_rng([seed, round])``, the same
stream on every graph of the round (so the strategies are compared on the same draws, as
the tilt-holder's are), uploads each session as a trace, and
prints one JSON line::

    {"graph", "round", "publication_id", "size_frames", "mean_error", "high_share",
     "steps", "sessions", "blend_share", "mean_score", "temperature",
     "hold_probabilities", "holds_played"}

``mean_error`` is the mean error per step over all its steps on that graph, ``high_share``
the share of steps whose error is above THRESHOLD (the dynamics' high-error threshold,
``srg analytics NAME --json`` prints it as ``threshold``)::

    python studies/outside-the-loop/learner.py URL STATE ROUND SEED THRESHOLD GRAPH [GRAPH ...]
"""

from __future__ import annotations

import argparse
import gzip
import json
import os
import sys
import tempfile
import time
import urllib.error
import urllib.request
from pathlib import Path
from typing import Any
from urllib.parse import quote

import numpy as np

HOLDS = (1, 2, 4, 8)
MEAN_STEPS = 60
SESSIONS = 30
#: a longer session is uploaded in pieces of at most this many steps (the server takes
#: 2,000 a trace; the web client splits at 1,800 too). At mean 60 it essentially never is.
PIECE = 1800
#: uploads refused for the rate (429) are retried after Retry-After, this many times
RETRIES = 20


# ---- HTTP -------------------------------------------------------------------------------
def request(
    url: str, *, body: Any = None, token: str | None = None, method: str | None = None
) -> tuple[int, Any]:
    """(status, JSON body) of a request; a 429 waits its Retry-After and tries again; any
    other HTTP error ends the run naming it."""
    data = None if body is None else json.dumps(body).encode()
    headers = {"Accept-Encoding": "gzip"}
    if data is not None:
        headers["Content-Type"] = "application/json"
    if token is not None:
        headers["Authorization"] = f"Bearer {token}"
    for _ in range(RETRIES + 1):
        call = urllib.request.Request(url, data=data, headers=headers, method=method)
        try:
            with urllib.request.urlopen(call, timeout=120) as answer:
                raw = answer.read()
                if answer.headers.get("Content-Encoding") == "gzip":
                    raw = gzip.decompress(raw)
                return answer.status, json.loads(raw) if raw else None
        except urllib.error.HTTPError as exc:
            text = exc.read().decode(errors="replace")
            if exc.code == 429:
                time.sleep(float(exc.headers.get("Retry-After") or 1))
                continue
            verb = method or ("POST" if data else "GET")
            raise SystemExit(f"{verb} {url}: {exc.code} {text}") from None
    raise SystemExit(f"{url}: still refused for the rate after {RETRIES} tries")


# ---- state ------------------------------------------------------------------------------
def load_state(path: Path) -> dict[str, Any]:
    if path.exists():
        state: dict[str, Any] = json.loads(path.read_text())
        return state
    return {"player": None, "rounds": {}}


def save_state(path: Path, state: dict[str, Any]) -> None:
    """Write the state whole or not at all (a temporary file renamed over it)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, name = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
    with os.fdopen(handle, "w") as out:
        json.dump(state, out, indent=1, sort_keys=True)
        out.write("\n")
    os.replace(name, path)


def player_token(url: str, path: Path, state: dict[str, Any]) -> str:
    """The state file's player, registered (as a bot) the first time."""
    if state.get("player") is None:
        _, player = request(f"{url}/api/players", body={"kind": "bot"})
        state["player"] = {k: player[k] for k in ("player_id", "name", "kind", "token")}
        save_state(path, state)
    return str(state["player"]["token"])


def memory_before(state: dict[str, Any], round_: int) -> dict[int, tuple[float, int]]:
    """Per hold length, (total score, total steps) of the rounds before ``round_``."""
    memory = {h: (0.0, 0) for h in HOLDS}
    for key, added in state["rounds"].items():
        if int(key) < round_:
            for h in HOLDS:
                score, steps = memory[h]
                memory[h] = (score + added[str(h)]["score"], steps + added[str(h)]["steps"])
    return memory


# ---- policy -----------------------------------------------------------------------------
def hold_probabilities(memory: dict[int, tuple[float, int]], round_: int) -> np.ndarray:
    """Softmax over each length's mean score per step over the best length's, at
    temperature 1 / (1 + round); an untried length counts as the best mean seen so far
    (all untried, or nothing scored yet: uniform)."""
    tried = {h: score / steps for h, (score, steps) in memory.items() if steps > 0}
    best = max(tried.values()) if tried else 0.0
    means = np.array([tried.get(h, best) for h in HOLDS]) / (best if best > 0 else 1.0)
    logits = means * (1.0 + round_)
    weights = np.exp(logits - logits.max())
    probabilities: np.ndarray = weights / weights.sum()
    return probabilities


def play_session(
    publication: dict[str, Any], hold: int, length: int, rng: np.random.Generator
) -> list[tuple[int, int]]:
    """``length`` steps from the start: the best-scoring control held ``hold`` steps, again."""
    vertices = publication["vertices"]
    vertex, control, held, steps = int(publication["start"]), 0, 0, []
    for _ in range(length):
        if held == 0:
            scores = np.array([edge["score"] for edge in vertices[vertex]], dtype=float)
            control = int(rng.choice(np.flatnonzero(scores == scores.max())))
            held = hold
        steps.append((vertex, control))
        vertex, held = int(vertices[vertex][control]["dst"]), held - 1
    return steps


def play_graph(
    url: str,
    token: str,
    graph: str,
    round_: int,
    seed: int,
    position: int,
    sessions: int,
    probabilities: np.ndarray,
    added: dict[int, list[float]],
) -> dict[str, Any]:
    """Play and upload ``sessions`` sessions on the graph's latest publication; add each
    session's score and steps to ``added`` (per hold length); the graph's report line."""
    _, publication = request(f"{url}/api/graphs/{quote(graph, safe='')}/publication")
    vertices = publication["vertices"]
    rng = np.random.default_rng([seed, round_])
    errors: list[float] = []
    blends: list[bool] = []
    holds = {h: 0 for h in HOLDS}
    scored = 0.0
    for s in range(sessions):
        hold = int(rng.choice(HOLDS, p=probabilities))
        length = max(int(rng.geometric(1.0 / MEAN_STEPS)), 2)
        steps = play_session(publication, hold, length, rng)
        for piece, start in enumerate(range(0, len(steps), PIECE)):
            key = (
                f"drift-r{round_}-p{publication['publication_id']}-s{seed}-g{position}-{s}-{piece}"
            )
            request(
                f"{url}/api/traces",
                token=token,
                body={
                    "publication_id": publication["publication_id"],
                    "idempotency_key": key,
                    "steps": [list(step) for step in steps[start : start + PIECE]],
                },
            )
        edges = [vertices[v][c] for v, c in steps]
        score = float(sum(edge["score"] for edge in edges))
        added[hold][0] += score
        added[hold][1] += len(steps)
        scored += score
        holds[hold] += 1
        # read for the report only: the policy above never looks at err or kind
        errors.extend(float(edge["err"]) for edge in edges)
        blends.extend(edge["kind"] == "blend" for edge in edges)
    line: dict[str, Any] = {"graph": graph, "round": round_}
    for field in ("publication_id", "size_frames"):
        if field in publication:
            line[field] = publication[field]
    return line | {
        "errors": np.asarray(errors),
        "blend_share": float(np.mean(blends)),
        "mean_score": scored / len(errors),
        "sessions": sessions,
        "holds_played": {str(h): n for h, n in holds.items()},
    }


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("url", help="the server, e.g. http://127.0.0.1:8766")
    parser.add_argument(
        "state", type=Path, help="the learner's JSON state file (created if absent)"
    )
    parser.add_argument("round", type=int, help="the round, 0 first: temperature 1 / (1 + round)")
    parser.add_argument("seed", type=int, help="seed of the sessions (with the round)")
    parser.add_argument("threshold", type=float, help="high-error threshold of the dynamics")
    parser.add_argument("graphs", nargs="+", help="the graphs of this round, in a fixed order")
    parser.add_argument("--sessions", type=int, default=SESSIONS, help="sessions per graph")
    args = parser.parse_args(argv)
    if args.round < 0 or args.sessions < 1:
        parser.error("round must be >= 0 and sessions >= 1")
    url = args.url.rstrip("/")
    state = load_state(args.state)
    token = player_token(url, args.state, state)
    probabilities = hold_probabilities(memory_before(state, args.round), args.round)
    added: dict[int, list[float]] = {h: [0.0, 0] for h in HOLDS}
    lines = []
    for position, graph in enumerate(args.graphs):
        line = play_graph(
            url, token, graph, args.round, args.seed, position, args.sessions, probabilities, added
        )
        errors = line.pop("errors")
        line |= {
            "mean_error": float(errors.mean()),
            "high_share": float(np.mean(errors > args.threshold)),
            "steps": int(errors.size),
            "temperature": 1.0 / (1.0 + args.round),
            "hold_probabilities": {
                str(h): float(p) for h, p in zip(HOLDS, probabilities, strict=True)
            },
        }
        lines.append(line)
    state["rounds"][str(args.round)] = {
        str(h): {"score": score, "steps": int(steps)} for h, (score, steps) in added.items()
    }
    memory = memory_before(state, 1 + max(int(key) for key in state["rounds"]))
    state["memory"] = {
        str(h): {"score": score, "steps": steps, "mean": score / steps if steps else None}
        for h, (score, steps) in memory.items()
    }
    save_state(args.state, state)
    for line in lines:
        print(json.dumps(line), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
