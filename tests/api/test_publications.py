"""Stored publications by id: a graph's older versions stay playable over HTTP."""

from __future__ import annotations

from datetime import datetime, timedelta
from typing import Any

from api_helpers import Published
from fastapi.testclient import TestClient
from sqlalchemy.orm import Session

from app.bench.ingest import ToyGraph, build_toy_graph
from app.core.growth.expansion import expand_blend_edge
from app.store.artifacts import ArtifactStore
from app.store.graph_persistence import save_graph
from app.store.publications import publish


def grow_and_publish(session: Session, artifacts: ArtifactStore, toy: ToyGraph) -> int:
    """One more expansion, saved, then published: a new version of the graph."""
    graph = toy.graph
    expand_blend_edge(graph, toy.bank, toy.dynamics, int(graph.blend_edges()[0]))
    save_graph(session, toy.graph_id, graph, toy.bank, artifacts)
    publication_id = publish(session, toy.graph_id, graph)
    session.commit()
    return publication_id


def test_an_older_version_is_served_as_the_latest_route_served_it(
    client: TestClient, session: Session, artifacts: ArtifactStore
) -> None:
    """Each version as the latest route served it while it was the latest: the same
    body, the same ETag; then listed oldest first with the sizes they were published at."""
    toy = build_toy_graph(session, artifacts, name="versions")
    served: dict[int, tuple[bytes, str]] = {}
    sizes: dict[int, tuple[int, int, int]] = {}
    for _ in range(3):
        publication_id = grow_and_publish(session, artifacts, toy)
        latest = client.get("/api/graphs/versions/publication")
        assert latest.json()["publication_id"] == publication_id
        served[publication_id] = (latest.content, latest.headers["etag"])
        graph = toy.graph
        sizes[publication_id] = (graph.size_frames, graph.n_vertices, graph.n_edges)
    listed = client.get("/api/graphs/versions/publications")
    assert listed.status_code == 200
    assert [row["publication_id"] for row in listed.json()] == list(served)
    assert [row["number"] for row in listed.json()] == [1, 2, 3]
    assert {
        row["publication_id"]: (row["size_frames"], row["n_vertices"], row["n_edges"])
        for row in listed.json()
    } == sizes
    assert len({size for size, _, _ in sizes.values()}) == 3  # three different versions
    for row in listed.json():
        assert datetime.fromisoformat(row["created_at"]).utcoffset() == timedelta(0)
    for publication_id, (body, etag) in served.items():
        reply = client.get(f"/api/graphs/versions/publications/{publication_id}")
        assert reply.status_code == 200
        assert (reply.content, reply.headers["etag"]) == (body, etag)
        assert reply.headers["cache-control"] == "public, max-age=31536000, immutable"


def test_a_stored_publication_is_gzipped_and_answers_304(
    client: TestClient, published: Published
) -> None:
    url = f"/api/graphs/{published.name}/publications/{published.publication_id}"
    zipped = client.get(url, headers={"Accept-Encoding": "gzip"})
    assert zipped.status_code == 200 and zipped.headers["content-encoding"] == "gzip"
    assert zipped.headers["vary"] == "Accept-Encoding"
    plain = client.get(url, headers={"Accept-Encoding": "identity"})
    assert "content-encoding" not in plain.headers and plain.json() == zipped.json()
    again = client.get(url, headers={"If-None-Match": plain.headers["etag"]})
    assert again.status_code == 304 and again.content == b""
    assert "immutable" in again.headers["cache-control"]


def error(reply: Any) -> str:
    assert reply.status_code == 404, reply.text
    body = reply.json()
    assert set(body) == {"error", "details"}
    return str(body["error"])


def test_unknown_graphs_and_other_graphs_publications_are_404(
    client: TestClient, published: Published, session: Session, artifacts: ArtifactStore
) -> None:
    other = build_toy_graph(session, artifacts, name="other")
    others = publish(session, other.graph_id, other.graph)
    session.commit()
    assert error(client.get("/api/graphs/nope/publications")) == "no graph 'nope'"
    by_id = f"/api/graphs/nope/publications/{published.publication_id}"
    assert error(client.get(by_id)) == "no graph 'nope'"
    theirs = f"/api/graphs/{published.name}/publications/{others}"
    assert error(client.get(theirs)) == f"no publication {others} of graph 'api-toy'"
    unknown = f"/api/graphs/{published.name}/publications/{2**31 - 1}"
    assert error(client.get(unknown)).startswith("no publication")
    for bad in ("0", str(2**31), "1.5", "one"):  # not a row id: a 422, never a driver error
        reply = client.get(f"/api/graphs/{published.name}/publications/{bad}")
        assert reply.status_code == 422 and set(reply.json()) == {"error", "details"}, bad


def test_a_graph_never_published_lists_none(
    client: TestClient, session: Session, artifacts: ArtifactStore
) -> None:
    build_toy_graph(session, artifacts, name="unpublished")
    session.commit()
    reply = client.get("/api/graphs/unpublished/publications")
    assert reply.status_code == 200 and reply.json() == []


def test_the_document_lists_both_routes(client: TestClient) -> None:
    paths = client.get("/openapi.json").json()["paths"]
    listed = paths["/api/graphs/{name}/publications"]["get"]
    by_id = paths["/api/graphs/{name}/publications/{publication_id}"]["get"]
    assert {"200", "404"} <= set(listed["responses"])
    assert {"200", "304", "404", "422"} <= set(by_id["responses"])
    item = listed["responses"]["200"]["content"]["application/json"]["schema"]["items"]
    assert item == {"$ref": "#/components/schemas/PublicationListed"}
