"""The API tells the truth: its document, 405 and Allow, HEAD, ETag and gzip, health, CORS,
every body bounded, JSON Schema's integers and RFC 3339's timestamps."""

from __future__ import annotations

from collections.abc import Iterator
from datetime import datetime, timedelta
from pathlib import Path
from typing import Any

import pytest
from api_helpers import ADMIN_TOKEN, Published, make_client, player_count, register, walk
from fastapi.testclient import TestClient
from sqlalchemy.orm import Session

from app.api.app import create_app
from app.config import Settings
from app.store.epochs import finish_epoch, start_epoch

ADMIN = {"Authorization": f"Bearer {ADMIN_TOKEN}"}
ERROR_BODY = "#/components/schemas/ErrorBody"


@pytest.fixture
def document(client: TestClient) -> dict[str, Any]:
    reply = client.get("/openapi.json")
    assert reply.status_code == 200
    return reply.json()


def operations(document: dict[str, Any]) -> Iterator[tuple[str, str, dict[str, Any]]]:
    for path, methods in document["paths"].items():
        for method, operation in methods.items():
            yield path, method, operation


def test_the_document_declares_the_error_body_every_route_sends(
    document: dict[str, Any],
) -> None:
    error_body = document["components"]["schemas"]["ErrorBody"]
    assert set(error_body["required"]) == {"error", "details"}
    assert "HTTPValidationError" not in document["components"]["schemas"]
    declared = {}
    for path, method, operation in operations(document):
        errors = {int(s) for s in operation["responses"] if s.startswith(("4", "5"))}
        for status in errors:
            schema = operation["responses"][str(status)]["content"]["application/json"]["schema"]
            assert schema == {"$ref": ERROR_BODY}, (method, path, status)
        declared[f"{method.upper()} {path}"] = errors
    assert declared["POST /api/traces"] == {400, 401, 403, 404, 409, 413, 422, 429, 503}
    assert declared["POST /api/players"] == {400, 413, 422, 429, 503}
    assert declared["POST /api/graphs/{name}/grow"] == {400, 401, 403, 404, 409, 413, 422, 503}
    assert declared["POST /api/graphs/{name}/publish"] == {400, 401, 403, 404, 413, 503}
    assert declared["GET /api/graphs/{name}/epochs"] == {400, 401, 403, 404, 422, 503}
    assert declared["GET /api/animations/{digest}/poster"] == {400, 404, 422, 503}
    # every route reads the database, and every request's Content-Length is read
    assert all({400, 503} <= statuses for statuses in declared.values())
    assert declared["GET /api/health"] == {400, 503}
    retry_after = document["paths"]["/api/traces"]["post"]["responses"]["429"]["headers"]
    assert "Retry-After" in retry_after


def test_the_document_declares_bearer_auth_and_the_media_types(document: dict[str, Any]) -> None:
    schemes = document["components"]["securitySchemes"]
    assert schemes["playerToken"] == {**schemes["playerToken"], "type": "http", "scheme": "bearer"}
    assert schemes["adminToken"] == {**schemes["adminToken"], "type": "http", "scheme": "bearer"}
    secured = {
        f"{method.upper()} {path}": [name for entry in op.get("security", []) for name in entry]
        for path, method, op in operations(document)
    }
    assert secured["POST /api/traces"] == ["playerToken"]
    for admin_route in ("publish", "grow", "epochs"):
        (route,) = [r for r in secured if r.endswith(f"/{admin_route}")]
        assert secured[route] == ["adminToken"]
    assert secured["POST /api/players"] == secured["GET /api/graphs"] == []
    poster = document["paths"]["/api/animations/{digest}/poster"]
    assert list(poster["get"]["responses"]["200"]["content"]) == ["image/webp"]


@pytest.mark.parametrize(
    ("method", "path", "allow"),
    [
        ("PUT", "/api/players", "POST"),
        ("GET", "/api/players", "POST"),
        ("POST", "/api/graphs", "GET, HEAD"),
        ("DELETE", "/api/graphs/g/publication", "GET, HEAD"),
        ("POST", "/api/animations/abc", "GET, HEAD"),
        ("GET", "/api/traces", "POST"),
        ("OPTIONS", "/api/traces", "POST"),
        ("PATCH", "/api/graphs/g/grow", "POST"),
        # methods of no route at all (WebDAV's), once left to the web client's files
        ("PROPFIND", "/api/graphs", "GET, HEAD"),
        ("MKCOL", "/api/traces", "POST"),
    ],
)
def test_a_wrong_method_is_405_with_the_path_s_methods_in_allow(
    client: TestClient, method: str, path: str, allow: str
) -> None:
    reply = client.request(method, path)
    assert reply.status_code == 405
    assert reply.headers["Allow"] == allow
    assert reply.json() == {"error": f"{method} is not allowed on {path}", "details": None}


def test_an_unknown_api_path_is_404_whatever_the_method(client: TestClient) -> None:
    for method in ("GET", "POST", "DELETE", "PROPFIND"):
        reply = client.request(method, "/api/nowhere")
        assert reply.status_code == 404
        assert reply.json() == {"error": "no route /api/nowhere", "details": None}


def test_every_get_route_answers_head_as_get_without_the_body(
    client: TestClient, published: Published, document: dict[str, Any]
) -> None:
    """HEAD of a JSON route was a 405: every GET route of the document answers HEAD with
    GET's status and headers, whether the GET succeeds or not."""
    urls = ["/api/graphs/nope/publication", f"/api/animations/{'0' * 64}/poster?frames=0"]
    for path, methods in document["paths"].items():
        if "get" in methods:
            url = path.replace("{name}", published.name).replace("{digest}", published.animation)
            url = url.replace("{publication_id}", str(published.publication_id))
            urls.append(f"{url}?frames=1")  # read by the poster and the phone clip only
    for url in urls:
        got, head = client.get(url, headers=ADMIN), client.head(url, headers=ADMIN)
        assert (head.status_code, head.headers) == (got.status_code, got.headers), url
        assert head.content == b"", url
    assert sum(client.get(url, headers=ADMIN).status_code == 200 for url in urls) >= 5
    refused = client.head("/api/players")  # no GET there: HEAD is not allowed either
    assert (refused.status_code, refused.headers["Allow"]) == (405, "POST")


def test_head_on_clips_answers_the_headers_of_get(client: TestClient, published: Published) -> None:
    url = f"/api/animations/{published.animation}"
    got, head = client.get(url), client.head(url)
    assert head.status_code == 200 and head.content == b""
    for header in ("content-length", "content-type", "etag", "cache-control"):
        assert head.headers[header] == got.headers[header]
    assert client.head(url, headers={"If-None-Match": got.headers["etag"]}).status_code == 304
    assert client.head(f"/api/animations/{'0' * 64}").status_code == 404
    assert client.head(f"{url}/poster?frames=10").status_code == 422  # not a real strip


def test_the_publication_has_an_etag_and_is_gzipped(
    client: TestClient, published: Published
) -> None:
    url = f"/api/graphs/{published.name}/publication"
    zipped = client.get(url, headers={"Accept-Encoding": "gzip"})
    assert zipped.status_code == 200
    assert zipped.headers["content-encoding"] == "gzip"
    assert zipped.headers["vary"] == "Accept-Encoding"
    assert int(zipped.headers["content-length"]) < len(zipped.content)  # compressed on the wire
    plain = client.get(url, headers={"Accept-Encoding": "identity"})
    assert "content-encoding" not in plain.headers
    assert plain.json() == zipped.json()
    etag = zipped.headers["etag"]
    assert etag == plain.headers["etag"] and etag.startswith('W/"')
    again = client.get(url, headers={"If-None-Match": etag})
    assert again.status_code == 304 and again.content == b""
    assert again.headers["etag"] == etag
    client.post(f"/api/graphs/{published.name}/publish", headers=ADMIN)
    newer = client.get(url, headers={"If-None-Match": etag})
    assert newer.status_code == 200 and newer.headers["etag"] != etag


def test_health_says_the_database_answers(client: TestClient, db_url: str) -> None:
    """No broker configured (the embedded default): healthy, the broker not asked."""
    reply = client.get("/api/health")
    assert reply.status_code == 200
    assert reply.json() == {
        "status": "ok",
        "database": db_url.split(":")[0].split("+")[0],
        "rate_limits": "per-process",
        "broker": "not configured",
        "workers": None,
    }


def test_health_is_200_and_says_so_when_the_broker_is_unreachable(
    session: Session, db_url: str, artifact_dir: Path
) -> None:
    """Players need no broker: a load balancer must not pull the server for it."""
    down = {"broker_url": "redis://127.0.0.1:1/0"}
    with make_client(session, db_url, artifact_dir, **down) as client:
        reply = client.get("/api/health")
    assert reply.status_code == 200
    assert (reply.json()["broker"], reply.json()["workers"]) == ("unreachable", None)


def test_health_is_503_when_the_database_does_not_answer(tmp_path: Path) -> None:
    settings = Settings().replace(
        database_url="postgresql+psycopg://postgres@127.0.0.1:1/none",
        artifact_dir=tmp_path,
        rate_limit_storage="memory://",
    )
    with TestClient(create_app(settings)) as client:
        reply = client.get("/api/health")
    assert reply.status_code == 503
    assert reply.json() == {
        "error": "the postgresql database does not answer",
        "details": {"database": "postgresql", "reason": "OperationalError"},
    }


def test_cors_is_off_by_default(client: TestClient) -> None:
    origin = {"Origin": "https://elsewhere.example"}
    assert "access-control-allow-origin" not in client.get("/api/graphs", headers=origin).headers
    preflight = client.options(
        "/api/traces", headers={**origin, "Access-Control-Request-Method": "POST"}
    )
    assert preflight.status_code == 405
    assert "access-control-allow-origin" not in preflight.headers


def test_cors_allows_the_configured_origins(
    session: Session, db_url: str, artifact_dir: Path
) -> None:
    allowed, other = "https://game.example", "https://elsewhere.example"
    with make_client(
        session, db_url, artifact_dir, cors_origins=f"{allowed}, https://b.example"
    ) as c:
        preflight = c.options(
            "/api/traces",
            headers={
                "Origin": allowed,
                "Access-Control-Request-Method": "POST",
                "Access-Control-Request-Headers": "authorization, content-type",
            },
        )
        assert preflight.status_code == 200
        assert preflight.headers["access-control-allow-origin"] == allowed
        assert "POST" in preflight.headers["access-control-allow-methods"]
        reply = c.post("/api/players", headers={"Origin": allowed})
        assert reply.status_code == 201
        assert reply.headers["access-control-allow-origin"] == allowed
        refused = c.get("/api/graphs", headers={"Origin": other})
        assert "access-control-allow-origin" not in refused.headers


def test_every_body_is_bounded(
    session: Session, db_url: str, artifact_dir: Path, published: Published
) -> None:
    """Not only traces: a player's or a grow request's body too, declared or streamed."""
    before = player_count(session)
    too_large = {"error": "body larger than 64 bytes", "details": {"max_bytes": 64}}
    with make_client(session, db_url, artifact_dir, max_body_bytes=64) as small:
        padded = {"kind": "person", "padding": "x" * 100}
        routes_with_bodies = [("/api/players", {}), (f"/api/graphs/{published.name}/grow", ADMIN)]
        for url, headers in routes_with_bodies:
            reply = small.post(url, json=padded, headers=headers)
            assert (reply.status_code, reply.json()) == (413, too_large), url
            chunks = (b" " * 16 for _ in range(10))  # no Content-Length: counted as it streams
            streamed = small.post(url, content=chunks, headers=headers)
            assert (streamed.status_code, streamed.json()) == (413, too_large), url
        # A route without a body never reads one; a declared one over the limit is refused.
        publish = small.post(f"/api/graphs/{published.name}/publish", json=padded, headers=ADMIN)
        assert (publish.status_code, publish.json()) == (413, too_large)
        assert small.post("/api/players", json={"kind": "bot"}).status_code == 201
        epochs = small.get(f"/api/graphs/{published.name}/epochs", headers=ADMIN).json()
    assert epochs["epochs"] == []
    assert player_count(session) == before + 1


@pytest.mark.parametrize("lengths", [["abc"], ["-1"], ["5, 7"], ["5", "7"]])
def test_a_malformed_content_length_is_a_400_in_the_error_shape(
    client: TestClient, session: Session, lengths: list[str]
) -> None:
    """It was let through here (and answered by uvicorn in plain text: test_over_http)."""
    before = player_count(session)
    headers = [("Content-Type", "application/json")]
    headers += [("Content-Length", length) for length in lengths]
    reply = client.post("/api/players", content=b'{"kind": "bot"}', headers=headers)
    assert (reply.status_code, reply.json()) == (
        400,
        {
            "error": "malformed Content-Length: it must be one decimal number of bytes",
            "details": None,
        },
    )
    assert player_count(session) == before
    same_twice = [("Content-Type", "application/json"), ("Content-Length", "15, 15")]
    assert client.post("/api/players", content=b'{"kind": "bot"}', headers=same_twice).is_success


def test_an_integral_float_is_a_json_schema_integer(
    client: TestClient, published: Published
) -> None:
    """The document says integer, and JSON Schema's integer takes 211.0: so does the API."""
    grow = f"/api/graphs/{published.name}/grow"
    reply = client.post(grow, json={"expansions": 1.0}, headers=ADMIN)
    assert (reply.status_code, reply.json()["expansions"]) == (202, 1)
    steps = [
        [float(vertex), float(control)] for vertex, control in walk(published.publication, [0])
    ]
    upload = {"publication_id": float(published.publication_id), "idempotency_key": "float"}
    stored = client.post("/api/traces", json={**upload, "steps": steps}, headers=register(client))
    assert (stored.status_code, stored.json()["n_steps"]) == (201, 1), stored.text
    for not_integral in (1.5, True, "1"):
        refused = client.post(grow, json={"expansions": not_integral}, headers=ADMIN)
        assert refused.status_code == 422, not_integral
        assert refused.json()["details"] == [
            {"loc": ["body", "expansions"], "msg": "Input should be a valid integer"}
        ]


def test_every_timestamp_carries_its_utc_offset(
    client: TestClient, published: Published, session: Session
) -> None:
    """RFC 3339 (the document's date-time) requires an offset; SQLite's had none."""
    epoch_id = start_epoch(session, published.graph_id, "sr-crowd")
    finish_epoch(session, epoch_id, expansions=1, relinks=0, size_frames=60)
    session.commit()
    (epoch,) = client.get(f"/api/graphs/{published.name}/epochs", headers=ADMIN).json()["epochs"]
    for timestamp in (epoch["started_at"], epoch["finished_at"]):
        assert datetime.fromisoformat(timestamp).utcoffset() == timedelta(0), timestamp
