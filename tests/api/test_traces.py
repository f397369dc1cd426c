"""Trace upload: every error path answers JSON and writes nothing; replays are idempotent."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from api_helpers import ADMIN_TOKEN, Published, make_client, register, row_counts, walk
from fastapi.testclient import TestClient
from sqlalchemy.orm import Session

from app.api.app import STATIC_DIR
from app.config import ApiSettings


def body(published: Published, steps: list[list[int]], key: str = "key-1") -> dict[str, object]:
    return {"publication_id": published.publication_id, "idempotency_key": key, "steps": steps}


def test_first_upload_201_then_replay_200_with_the_same_trace(
    client: TestClient, player: dict[str, str], published: Published, session: Session
) -> None:
    steps = walk(published.publication, [0, 1, 1, 2, 0, 2])
    first = client.post("/api/traces", json=body(published, steps), headers=player)
    assert first.status_code == 201, first.text
    assert first.json()["created"] is True and first.json()["n_steps"] == 6
    replay = client.post("/api/traces", json=body(published, steps), headers=player)
    assert replay.status_code == 200
    assert replay.json()["trace_id"] == first.json()["trace_id"]
    assert replay.json()["created"] is False
    assert row_counts(session) == (1, 6, 6)


def test_the_same_key_for_another_trace_is_a_409(
    client: TestClient, player: dict[str, str], published: Published, session: Session
) -> None:
    first = walk(published.publication, [0])
    client.post("/api/traces", json=body(published, first), headers=player)
    other = walk(published.publication, [1, 1])
    reply = client.post("/api/traces", json=body(published, other), headers=player)
    assert reply.status_code == 409 and "idempotency key" in reply.json()["error"]
    assert row_counts(session) == (1, 1, 1)


def test_keys_are_per_player(
    client: TestClient, player: dict[str, str], published: Published, session: Session
) -> None:
    steps = walk(published.publication, [2, 2])
    reply = client.post("/api/traces", json=body(published, steps), headers=player)
    assert reply.status_code == 201
    other = register(client)
    assert client.post("/api/traces", json=body(published, steps), headers=other).status_code == 201
    assert row_counts(session) == (2, 4, 4)


@pytest.mark.parametrize(
    ("headers", "status"),
    [
        ({}, 401),
        ({"Authorization": "Basic dXNlcjpwdw=="}, 401),
        ({"Authorization": "Bearer "}, 401),
        ({"Authorization": "Bearer not-a-token"}, 403),
    ],
)
def test_a_missing_or_unknown_token_is_refused(
    client: TestClient, published: Published, session: Session, headers: dict, status: int
) -> None:
    steps = walk(published.publication, [0, 1])
    reply = client.post("/api/traces", json=body(published, steps), headers=headers)
    assert reply.status_code == status
    assert reply.json()["error"]
    if status == 401:
        assert reply.headers["WWW-Authenticate"] == "Bearer"
    assert row_counts(session) == (0, 0, 0)


def test_an_unknown_publication_is_a_404(
    client: TestClient, player: dict[str, str], published: Published, session: Session
) -> None:
    payload = body(published, walk(published.publication, [0]))
    payload["publication_id"] = published.publication_id + 1000
    reply = client.post("/api/traces", json=payload, headers=player)
    assert reply.status_code == 404 and "publication" in reply.json()["error"]
    assert row_counts(session) == (0, 0, 0)


def test_a_step_off_the_edges_is_a_422_and_writes_nothing(
    client: TestClient, player: dict[str, str], published: Published, session: Session
) -> None:
    steps = walk(published.publication, [0, 1, 2])
    wrong_next = (steps[1][0] + 1) % published.publication.n_vertices
    steps[1][0] = wrong_next
    reply = client.post("/api/traces", json=body(published, steps), headers=player)
    assert reply.status_code == 422
    led_to = published.publication.destination(*steps[0])
    assert reply.json() == {  # which step failed, and why
        "error": f"step 1 does not follow the edges of publication {published.publication_id}: "
        f"step 0's edge ({steps[0][0]}, {steps[0][1]}) leads to vertex {led_to}, not {wrong_next}",
        "details": {"step": 1, "vertex": wrong_next, "control": steps[1][1]},
    }
    n = published.publication.n_vertices
    for off_graph, why in (
        ([[0, 0], [n, 0]], f"vertex {n} is not in 0..{n - 1}"),
        ([[0, 3]], "control 3 is not in 0..2"),
    ):
        reply = client.post("/api/traces", json=body(published, off_graph), headers=player)
        assert reply.status_code == 422
        step = len(off_graph) - 1
        assert reply.json()["error"].startswith(f"step {step} does not follow")
        assert reply.json()["error"].endswith(why)
        assert reply.json()["details"]["step"] == step
    assert row_counts(session) == (0, 0, 0)


@pytest.mark.parametrize(
    ("payload", "where"),
    [
        ({"idempotency_key": "k", "steps": [[0, 0]]}, "publication_id"),
        ({"publication_id": 1, "idempotency_key": "k", "steps": []}, "steps"),
        ({"publication_id": 1, "idempotency_key": "k", "steps": [[0, True]]}, "steps"),
        ({"publication_id": 1, "idempotency_key": "k", "steps": [[0, 1.5]]}, "steps"),
        ({"publication_id": 1, "idempotency_key": "k", "steps": [[0, 1, 2]]}, "steps"),
        ({"publication_id": 1, "idempotency_key": "k", "steps": [[-1, 0]]}, "steps"),
        ({"publication_id": 1, "idempotency_key": "k", "steps": [[2**40, 0]]}, "steps"),
        ({"publication_id": 1, "idempotency_key": "a\u0000", "steps": [[0, 0]]}, "idempotency_key"),
        ({"publication_id": 1, "idempotency_key": "k" * 129, "steps": [[0, 0]]}, "idempotency_key"),
        ({"publication_id": "1", "idempotency_key": "k", "steps": [[0, 0]]}, "publication_id"),
        ({"publication_id": 1, "idempotency_key": "k", "steps": [[0, 0]], "x": 1}, "x"),
        ([1, 2, 3], ""),
    ],
)
def test_schema_errors_are_422_saying_where(
    client: TestClient,
    player: dict[str, str],
    published: Published,
    session: Session,
    payload: object,
    where: str,
) -> None:
    reply = client.post("/api/traces", json=payload, headers=player)
    assert reply.status_code == 422
    answer = reply.json()
    assert answer["error"] == "invalid trace upload"
    assert any(where in detail["loc"] for detail in answer["details"]) or not where
    assert row_counts(session) == (0, 0, 0)


def test_a_body_that_is_not_json_is_a_422(
    client: TestClient, player: dict[str, str], published: Published
) -> None:
    reply = client.post("/api/traces", content=b"{not json", headers=player)
    assert reply.status_code == 422 and reply.json()["details"]


def test_a_too_large_body_is_a_413_before_parsing(
    session: Session, db_url: str, artifact_dir: Path, published: Published
) -> None:
    with make_client(session, db_url, artifact_dir, max_trace_bytes=200) as small:
        headers = register(small)
        steps = walk(published.publication, [0, 1, 2] * 20)
        reply = small.post("/api/traces", json=body(published, steps), headers=headers)
        assert reply.status_code == 413
        assert reply.json() == {
            "error": "body larger than 200 bytes",
            "details": {"max_bytes": 200},
        }
        # No Content-Length (chunked): counted while it streams in, refused all the same.
        chunks = (b"x" * 64 for _ in range(10))
        streamed = small.post("/api/traces", content=chunks, headers=headers)
        assert streamed.status_code == 413
        # Just under the limit is parsed (and here found invalid: not JSON).
        assert small.post("/api/traces", content=b"x" * 200, headers=headers).status_code == 422
    assert row_counts(session) == (0, 0, 0)


def test_two_traces_longer_than_a_session_are_refused_and_write_nothing(
    client: TestClient, player: dict[str, str], published: Published, session: Session
) -> None:
    """The finding: one fresh player's two 85,000-step traces (under 1 MB) were stored."""
    steps = walk(published.publication, [1] * 85_000)
    for key in ("huge-1", "huge-2"):
        reply = client.post("/api/traces", json=body(published, steps, key), headers=player)
        assert reply.status_code == 413, reply.text
        assert reply.json() == {
            "error": "a trace of 85000 steps; at most 2000 are accepted per trace",
            "details": {"max_steps": 2000},
        }
    assert row_counts(session) == (0, 0, 0)


def test_the_longest_traces_accepted_leave_growth_working(
    client: TestClient, player: dict[str, str], published: Published
) -> None:
    """Two traces of the most steps accepted, circling one loop: the graph still grows."""
    steps = walk(published.publication, [1] * 2000)
    for key in ("long-1", "long-2"):
        reply = client.post("/api/traces", json=body(published, steps, key), headers=player)
        assert reply.status_code == 201, reply.text
    admin = {"Authorization": f"Bearer {ADMIN_TOKEN}"}
    grow = f"/api/graphs/{published.name}/grow"
    reply = client.post(grow, json={"expansions": 4}, headers=admin)
    assert reply.status_code == 202, reply.text
    epochs = client.get(reply.json()["poll"], headers=admin).json()["epochs"]
    assert [(e["status"], e["expansions"]) for e in epochs] == [("finished", 4)]


def test_traces_up_to_the_step_limit_are_stored(
    session: Session, db_url: str, artifact_dir: Path, published: Published
) -> None:
    with make_client(session, db_url, artifact_dir, max_trace_steps=5) as limited:
        headers = register(limited)
        at_limit = body(published, walk(published.publication, [1] * 5), key="five")
        assert limited.post("/api/traces", json=at_limit, headers=headers).status_code == 201
        over = body(published, walk(published.publication, [1] * 6), key="six")
        reply = limited.post("/api/traces", json=over, headers=headers)
        assert reply.status_code == 413 and reply.json()["details"] == {"max_steps": 5}
    assert row_counts(session) == (1, 5, 5)


def test_the_step_limit_leaves_room_for_the_web_client() -> None:
    source = (STATIC_DIR / "client.js").read_text()
    found = re.search(r"const MAX_TRACE_STEPS = (\d+);", source)
    assert found is not None
    client_limit = int(found.group(1))
    server_limit = ApiSettings.model_fields["max_trace_steps"].default
    assert client_limit < server_limit <= 2 * client_limit


def test_uploads_over_the_rate_are_429_with_retry_after(
    session: Session, db_url: str, artifact_dir: Path, published: Published
) -> None:
    with make_client(session, db_url, artifact_dir, uploads_per_minute=2) as limited:
        headers, other = register(limited), register(limited)
        statuses = [
            limited.post(
                "/api/traces",
                json=body(published, walk(published.publication, [0]), key=f"k{i}"),
                headers=headers,
            )
            for i in range(3)
        ]
        assert [r.status_code for r in statuses] == [201, 201, 429]
        refused = statuses[2]
        assert int(refused.headers["Retry-After"]) >= 1
        assert refused.json()["error"].startswith("too many uploads")
        # The limit is per player.
        payload = body(published, walk(published.publication, [1]), key="k0")
        assert limited.post("/api/traces", json=payload, headers=other).status_code == 201
    assert row_counts(session) == (3, 3, 3)
