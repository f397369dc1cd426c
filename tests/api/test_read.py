"""Graphs, publications, animation files, players, admin auth, the static client."""

from __future__ import annotations

import io
import logging
from pathlib import Path

import numpy as np
import pytest
from api_helpers import ADMIN_TOKEN, Published
from artifact_helpers import flip_in_place
from fastapi.testclient import TestClient
from PIL import Image
from sqlalchemy import func, select
from sqlalchemy.orm import Session

from app.bench.ingest import build_toy_graph
from app.core.graph.toy import ToyDynamics
from app.models import Player
from app.render.animation import STRIP_MEDIA_TYPE, decode_strip
from app.services.status import graph_summary
from app.store.artifacts import ArtifactStore
from app.store.graph_persistence import load_graph
from app.store.publications import publish

ADMIN = {"Authorization": f"Bearer {ADMIN_TOKEN}"}


def test_graphs_list_the_latest_publication(
    client: TestClient, published: Published, session: Session, artifacts: ArtifactStore
) -> None:
    """With whether it has animations: one made for bots has none, one never made neither."""
    for_bots = build_toy_graph(session, artifacts, name="for-bots")
    publish(session, for_bots.graph_id, for_bots.graph)
    build_toy_graph(session, artifacts, name="unpublished")
    session.commit()
    reply = client.get("/api/graphs")
    assert reply.status_code == 200
    graph, bots, unpublished = reply.json()
    assert graph["name"] == published.name
    assert graph["latest_publication"] == 1 and graph["animated"]
    assert bots["latest_publication"] == 1 and not bots["animated"]
    assert unpublished["latest_publication"] is None and not unpublished["animated"]


def test_graphs_and_srg_status_name_the_latest_publication_alike(
    client: TestClient, published: Published, session: Session, artifacts: ArtifactStore
) -> None:
    """The finding: ``srg status`` said a graph's latest publication was 1 (its number)
    where ``GET /api/graphs`` said 7 (its id). Both say the number now, the publication's
    own ``number``."""
    twice = build_toy_graph(session, artifacts, name="twice")
    for _ in range(2):
        publish(session, twice.graph_id, twice.graph)
    session.commit()
    listed = {
        graph["name"]: graph["latest_publication"] for graph in client.get("/api/graphs").json()
    }
    assert listed == {name: graph_summary(session, name)["latest_publication"] for name in listed}
    assert listed == {published.name: 1, "twice": 2}
    latest = client.get("/api/graphs/twice/publication").json()
    assert latest["number"] == 2 != latest["publication_id"]  # ids count every graph's


def test_the_publication_carries_every_edge(client: TestClient, published: Published) -> None:
    reply = client.get(f"/api/graphs/{published.name}/publication")
    assert reply.status_code == 200
    data = reply.json()
    core = published.publication
    assert data["publication_id"] == published.publication_id
    assert (data["start"], data["n_controls"], data["fps"]) == (core.start, 3, 30.0)
    assert data["frames_per_clip"] == 10 and data["n_vertices"] == core.n_vertices
    edges = [e for vertex in data["vertices"] for e in vertex]
    assert [e["dst"] for e in edges] == core.edge_dst.tolist()
    assert np.allclose([e["score"] for e in edges], core.edge_score)
    assert np.allclose([e["err"] for e in edges], core.edge_err)
    assert [e["kind"] == "blend" for e in edges] == (core.edge_kind == 1).tolist()
    assert edges[0]["animation"] == f"/api/animations/{published.animation}"
    assert all(e["animation"] is None for e in edges[1:])


def test_the_publication_tells_its_size_and_blends(
    client: TestClient, published: Published, session: Session
) -> None:
    data = client.get(f"/api/graphs/{published.name}/publication").json()
    core = published.publication
    blends = core.edge_kind == 1
    graph = load_graph(
        session, published.graph_id, ArtifactStore(Path("unused")), ToyDynamics().shape
    )[0]
    assert data["size_frames"] == graph.size_frames > 0
    assert blends.any() and data["blend_share"] == pytest.approx(blends.mean())
    assert data["mean_blend_error"] == pytest.approx(core.edge_err[blends].mean())


def test_unknown_graphs_and_unpublished_graphs_are_404(
    client: TestClient, published: Published
) -> None:
    reply = client.get("/api/graphs/nope/publication")
    assert reply.status_code == 404 and reply.json() == {
        "error": "no graph 'nope'",
        "details": None,
    }
    assert client.get("/api/nowhere").json() == {"error": "no route /api/nowhere", "details": None}


def test_animations_are_served_immutable_by_hash(client: TestClient, published: Published) -> None:
    url = f"/api/animations/{published.animation}"
    reply = client.get(url)
    assert reply.status_code == 200
    assert reply.content == b"RIFF-not-really-webp"
    assert reply.headers["content-type"] == "image/webp"
    assert reply.headers["etag"] == f'"{published.animation}"'
    assert "immutable" in reply.headers["cache-control"]
    assert "max-age=31536000" in reply.headers["cache-control"]
    again = client.get(url, headers={"If-None-Match": reply.headers["etag"]})
    assert again.status_code == 304 and again.content == b""


def test_a_corrupted_animation_is_never_served_under_its_hash(
    client: TestClient,
    published: Published,
    artifacts: ArtifactStore,
    caplog: pytest.LogCaptureFixture,
) -> None:
    """One bit flipped after the file was served, its size and modification time kept:
    503 with the usual body (never 200 with the hash as ETag, cached for a year), the file
    moved aside, and the next request answered the same way. The body names no path of
    the server; the log names the file."""
    url = f"/api/animations/{published.animation}"
    assert client.get(url).status_code == 200
    path = artifacts.path_for(published.animation)
    data = flip_in_place(path, 3)
    with caplog.at_level(logging.WARNING, logger="app.store.artifacts"):
        for method in (client.get, client.head, client.get):
            reply = method(url)
            assert reply.status_code == 503, reply.status_code
            assert "etag" not in reply.headers and "immutable" not in reply.headers.get(
                "cache-control", ""
            )
        body = client.get(url).json()
    assert "does not match its hash" in body["error"] and set(body) == {"error", "details"}
    assert str(artifacts.root) not in body["error"] and "/corrupt" not in body["error"]
    assert str(artifacts.corrupt_path(published.animation)) in caplog.text
    assert not path.exists()
    assert artifacts.corrupt_path(published.animation).read_bytes() == data


def test_only_stored_image_artifacts_are_served(client: TestClient, published: Published) -> None:
    for digest in ("0" * 64, "not-a-hash", published.bundle):
        reply = client.get(f"/api/animations/{digest}")
        assert reply.status_code == 404 and "no animation" in reply.json()["error"]


def test_players_get_distinct_tokens(client: TestClient) -> None:
    first, second = (client.post("/api/players", json={"kind": "bot"}).json() for _ in range(2))
    assert first["kind"] == "bot" and first["token"] != second["token"]
    assert first["name"] != second["name"]
    assert client.post("/api/players").json()["kind"] == "person"


def test_a_player_is_a_person_unless_it_says_bot(client: TestClient, session: Session) -> None:
    said = {"person": {"kind": "person"}, "bot": {"kind": "bot"}, "default": None}
    kinds = {name: client.post("/api/players", json=body).json() for name, body in said.items()}
    stored = {name: kind for name, kind in session.execute(select(Player.name, Player.kind))}
    assert {name: stored[reply["name"]] for name, reply in kinds.items()} == {
        "person": "person",
        "bot": "bot",
        "default": "person",
    }
    for kind in ("robot", "human", "", 1):  # "human" was the person's kind before
        reply = client.post("/api/players", json={"kind": kind})
        assert reply.status_code == 422 and set(reply.json()) == {"error", "details"}, kind
        assert reply.json()["details"][0]["loc"][-1] == "kind"
    assert session.scalar(select(func.count()).select_from(Player)) == 3  # none refused


def test_admin_actions_need_the_admin_token(client: TestClient, published: Published) -> None:
    for action in ("publish", "grow"):
        url = f"/api/graphs/{published.name}/{action}"
        assert client.post(url).status_code == 401
        wrong = client.post(url, headers={"Authorization": f"Bearer {ADMIN_TOKEN}x"})
        assert wrong.status_code == 403 and wrong.json()["error"] == "admin token required"


def test_the_web_client_is_served_at_the_root(client: TestClient) -> None:
    page = client.get("/")
    assert page.status_code == 200 and "client.js" in page.text
    assert client.get("/client.js").status_code == 200


def test_admin_grow_then_publish_serves_a_bigger_playable_publication(
    client: TestClient, published: Published
) -> None:
    admin = {"Authorization": f"Bearer {ADMIN_TOKEN}"}
    base = f"/api/graphs/{published.name}"
    before = client.get(f"{base}/publication").json()
    grown = client.post(f"{base}/grow", json={"expansions": 3}, headers=admin)
    assert grown.status_code == 202, grown.text
    epochs = client.get(grown.json()["poll"], headers=admin).json()["epochs"]
    assert sum(epoch["expansions"] for epoch in epochs) == 3
    published_again = client.post(f"{base}/publish", headers=admin)
    assert published_again.status_code == 200, published_again.text
    after = client.get(f"{base}/publication").json()
    assert after["number"] == before["number"] + 1
    assert after["n_vertices"] == before["n_vertices"] + 3
    edges = [edge for vertex in after["vertices"] for edge in vertex]
    assert all(edge["animation"] for edge in edges)  # publish renders what was missing
    assert client.post(f"{base}/grow", json={"expansions": 0}, headers=admin).status_code == 422
    assert client.post("/api/graphs/nope/grow", headers=admin).status_code == 404


def test_posters_are_the_first_frame_of_real_strips(
    client: TestClient, published: Published
) -> None:
    admin = {"Authorization": f"Bearer {ADMIN_TOKEN}"}
    assert client.post(f"/api/graphs/{published.name}/publish", headers=admin).status_code == 200
    data = client.get(f"/api/graphs/{published.name}/publication").json()
    edge = data["vertices"][data["start"]][1]
    k = data["frames_per_clip"]
    assert edge["poster"] == f"{edge['animation']}/poster?frames={k}"
    strip = decode_strip(client.get(edge["animation"]).content, k)
    reply = client.get(edge["poster"])
    assert reply.status_code == 200 and reply.headers["content-type"] == "image/webp"
    assert "immutable" in reply.headers["cache-control"]
    poster = np.asarray(Image.open(io.BytesIO(reply.content)).convert("RGB"))
    assert poster.shape == strip[0].shape
    assert np.abs(poster.astype(int) - strip[0].astype(int)).mean() < 8  # lossy WebP twice
    again = client.get(edge["poster"], headers={"If-None-Match": reply.headers["etag"]})
    assert again.status_code == 304
    bad = client.get(f"{edge['animation']}/poster", params={"frames": 7})
    assert bad.status_code == 422 and "not a strip of 7 frames" in bad.json()["error"]
    assert client.get(f"{edge['animation']}/poster").status_code == 422
    assert client.get(f"/api/animations/{'0' * 64}/poster?frames={k}").status_code == 404
    fake = client.get(f"/api/animations/{published.animation}/poster?frames={k}")
    assert fake.status_code == 422


def test_the_phone_strip_is_the_strip_at_half_size(
    client: TestClient, published: Published
) -> None:
    assert client.post(f"/api/graphs/{published.name}/publish", headers=ADMIN).status_code == 200
    data = client.get(f"/api/graphs/{published.name}/publication").json()
    edge = data["vertices"][data["start"]][1]
    k = data["frames_per_clip"]
    strip = decode_strip(client.get(edge["animation"]).content, k)
    reply = client.get(f"{edge['animation']}/phone", params={"frames": k})
    assert reply.status_code == 200 and reply.headers["content-type"] == STRIP_MEDIA_TYPE
    assert "immutable" in reply.headers["cache-control"]
    phone = decode_strip(reply.content, k)
    _, h, w, _ = strip.shape
    assert phone.shape == (k, round(h / 2), round(w / 2), 3)
    halved = [np.asarray(Image.fromarray(f).resize(phone.shape[2:0:-1])) for f in strip]
    assert np.abs(phone.astype(int) - np.stack(halved).astype(int)).mean() < 8
    again = client.get(
        f"{edge['animation']}/phone?frames={k}", headers={"If-None-Match": reply.headers["etag"]}
    )
    assert again.status_code == 304
    assert client.head(f"{edge['animation']}/phone?frames={k}").status_code == 200
    digest = edge["animation"].rsplit("/", 1)[-1]
    cut = client.app.state.derived.get_or_load((digest, "phone", k), bytes)  # type: ignore[attr-defined]
    assert cut == reply.content  # cut once, then served from the process's cache
    assert client.get(f"{edge['animation']}/phone", params={"frames": 7}).status_code == 422
    assert client.get(f"/api/animations/{'0' * 64}/phone?frames={k}").status_code == 404


@pytest.mark.parametrize(
    "name", ["%C2%B2", "99999999999999999999", "2147483648", "%D9%A3", "0", "a%00b"]
)
def test_odd_graph_names_and_ids_are_404_not_500(
    client: TestClient, published: Published, name: str
) -> None:
    """'²' and '٣' are str.isdigit() but no int; 10**20 overflows the database's integers."""
    requests = [
        ("GET", f"/api/graphs/{name}/publication", {}),
        ("GET", f"/api/graphs/{name}/publications", {}),
        ("GET", f"/api/graphs/{name}/publications/{published.publication_id}", {}),
        ("POST", f"/api/graphs/{name}/grow", {"headers": ADMIN}),
        ("POST", f"/api/graphs/{name}/publish", {"headers": ADMIN}),
        ("GET", f"/api/graphs/{name}/epochs", {"headers": ADMIN}),
    ]
    for method, url, extra in requests:
        reply = client.request(method, url, **extra)
        assert reply.status_code == 404, (method, url, reply.text)
        assert reply.json()["error"].startswith("no graph"), reply.text


def test_an_id_of_thousands_of_digits_is_a_404_not_a_500(
    client: TestClient, published: Published
) -> None:
    reply = client.get(f"/api/graphs/{'9' * 5000}/publication")
    assert reply.status_code == 404 and "(5000 characters)" in reply.json()["error"]
