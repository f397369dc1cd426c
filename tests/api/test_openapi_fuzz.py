"""Property: every route of the OpenAPI document answers < 500, whatever schemathesis sends.

Schemathesis generates path parameters, queries and bodies (valid and invalid) from the
app's own document, 25 examples a route, on SQLite and on PostgreSQL. Every answer must
also be one the document declares for that route (status, content type and body: 4xx
answers their ``{error, details}`` body, formats included: a ``date-time`` is RFC 3339's,
with its offset), so the document tells the truth. Every GET is sent again as a HEAD,
which must answer the same status and headers without a body.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import schemathesis
from api_helpers import ADMIN_TOKEN, Published, make_client, register
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, given, settings
from schemathesis import GenerationMode
from schemathesis.checks import (
    content_type_conformance,
    not_a_server_error,
    response_schema_conformance,
    status_code_conformance,
)
from schemathesis.config import SchemathesisConfig
from schemathesis.openapi import from_dict
from sqlalchemy.orm import Session

import app.api.routes.admin
from app.api.growth_jobs import GrowthJobs
from app.store.epochs import finish_epoch, start_epoch

#: the defaults, said here rather than left to a schemathesis.toml: formats are checked
CONFIG = SchemathesisConfig.from_dict(
    {"checks": {"response_schema_conformance": {"validate-formats": True}}}
)


def _no_growth(jobs: GrowthJobs, _scope: Any, _settings: Any, graph_id: int, *_: Any) -> None:
    """Admin grow's background job, minus the growth: what it answers is tested here."""
    jobs.release(graph_id)


@pytest.fixture
def fuzz_client(
    published: Published,
    session: Session,
    db_url: str,
    artifact_dir: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> Iterator[TestClient]:
    monkeypatch.setattr(app.api.routes.admin, "grow_in_background", _no_growth)
    epoch_id = start_epoch(session, published.graph_id, "sr-crowd")  # timestamps to check
    finish_epoch(session, epoch_id, expansions=1, relinks=0, size_frames=60)
    session.commit()
    unlimited = {
        "uploads_per_minute": 1_000_000,
        "address_upload_rate": "1000000/minute",
        "registration_rate": "1000000/minute",
    }
    with make_client(session, db_url, artifact_dir, **unlimited) as client:
        yield client


def test_no_route_answers_5xx(fuzz_client: TestClient, published: Published) -> None:
    schema = from_dict(fuzz_client.app.openapi(), config=CONFIG)  # type: ignore[attr-defined]
    operations = [result.ok() for result in schema.get_all_operations()]
    assert len(operations) >= 9  # every route of the document, admin ones included
    # besides generated names and digests, ones that exist: so 2xx answers are checked too
    known = {
        "name": published.name,
        "digest": published.animation,
        "publication_id": str(published.publication_id),
    }
    answered: Counter[tuple[str, int]] = Counter()
    for operation in operations:
        check_operation(fuzz_client, operation, known, answered)
    succeeded = {label for (label, status) in answered if status < 300}
    assert len(succeeded) >= 7, answered  # the 2xx checks ran on most routes


def check_operation(
    client: TestClient,
    operation: schemathesis.APIOperation,
    known: dict[str, str],
    answered: Counter[tuple[str, int]],
) -> None:
    admin = "admin" in (operation.definition.raw.get("tags") or [])
    player = register(client)["Authorization"]
    admin_token = f"Bearer {ADMIN_TOKEN}"
    cases = operation.as_strategy(GenerationMode.POSITIVE) | operation.as_strategy(
        GenerationMode.NEGATIVE
    )
    path_names = {parameter.name for parameter in operation.path_parameters}
    if path_names:
        existing = {name: known[name] for name in path_names}
        cases |= operation.as_strategy(GenerationMode.POSITIVE, path_parameters=existing)

    @settings(
        max_examples=25,
        deadline=None,
        derandomize=True,  # the same examples every run: a failure here is reproducible
        suppress_health_check=list(HealthCheck),
    )
    @given(case=cases)
    def check(case: schemathesis.Case) -> None:
        # the real token, over whatever the generated case put in Authorization
        headers = {**(case.headers or {}), "Authorization": admin_token if admin else player}
        request = case.as_transport_kwargs(base_url="http://testserver", headers=headers)
        if not request.get("cookies"):
            request.pop("cookies", None)  # the test client deprecates per-request cookies
        if isinstance(request.get("data"), bytes | str):
            request["content"] = request.pop("data")
        response = client.request(**request)
        answered[operation.label, response.status_code] += 1
        assert response.status_code < 500, (case.as_curl_command(), response.text)
        checks = [
            not_a_server_error,
            status_code_conformance,
            content_type_conformance,
            response_schema_conformance,
        ]
        case.validate_response(response, checks=checks)
        if request["method"] == "GET":
            head = client.request(**{**request, "method": "HEAD"})
            assert (head.status_code, head.headers) == (response.status_code, response.headers)
            assert head.content == b"", case.as_curl_command()

    check()
