"""API fixtures: an app whose requests run in the test's rolled-back session."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from api_helpers import Published, make_client, register
from fastapi.testclient import TestClient
from sqlalchemy.orm import Session

from app.bench.ingest import build_toy_graph
from app.store.animations import set_animations
from app.store.artifacts import ArtifactStore
from app.store.publications import load_publication, publish


@pytest.fixture
def published(session: Session, artifacts: ArtifactStore) -> Published:
    toy = build_toy_graph(session, artifacts, name="api-toy", expansions=2)
    digest = artifacts.put_bytes(b"RIFF-not-really-webp", media_type="image/webp", session=session)
    set_animations(session, toy.graph_id, edges={0: digest})
    publication_id = publish(session, toy.graph_id, toy.graph)
    bundle = artifacts.put_arrays({"x": toy.graph.edge_arrays()[0]}, session=session)
    session.commit()  # releases the test's savepoint: a rejected request cannot undo this
    return Published(
        name="api-toy",
        graph_id=toy.graph_id,
        publication_id=publication_id,
        publication=load_publication(session, publication_id),
        animation=digest,
        bundle=bundle,
    )


@pytest.fixture
def client(session: Session, db_url: str, artifact_dir: Path) -> Iterator[TestClient]:
    with make_client(session, db_url, artifact_dir) as test_client:
        yield test_client


@pytest.fixture
def player(client: TestClient) -> dict[str, str]:
    return register(client)
