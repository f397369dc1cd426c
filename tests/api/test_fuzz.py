"""Property: whatever the body, the trace endpoint answers < 500 and never writes half a trace."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from api_helpers import Published, make_client, register, row_counts, walk
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from sqlalchemy.orm import Session

json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(max_size=8),
    lambda children: (
        st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=6), children, max_size=4)
    ),
    max_leaves=12,
)
step_values = st.integers(min_value=-3, max_value=40) | st.integers() | st.booleans()


@st.composite
def uploads(draw: st.DrawFn, publication_id: int, valid: list[list[int]]) -> Any:
    """Mostly near-valid bodies (a valid walk with mutations), some arbitrary JSON."""
    if draw(st.integers(0, 4)) == 0:
        return draw(json_values)
    steps: list[Any] = [list(s) for s in valid[: draw(st.integers(0, len(valid)))]]
    steps += draw(st.lists(st.lists(step_values, min_size=0, max_size=3), max_size=3))
    body: dict[str, Any] = {
        "publication_id": draw(st.sampled_from([publication_id, publication_id + 99, 0, "1"])),
        "idempotency_key": draw(st.text(max_size=6) | st.sampled_from(["a", "b", "c"])),
        "steps": draw(st.permutations(steps)) if draw(st.booleans()) else steps,
    }
    if draw(st.booleans()):
        body.pop(draw(st.sampled_from(sorted(body))))
    return body


def test_fuzzed_uploads_never_fail_the_server_or_write_partially(
    published: Published, session: Session, db_url: str, artifact_dir: Path
) -> None:
    with make_client(session, db_url, artifact_dir, uploads_per_minute=100_000) as client:
        fuzz(client, published, session)


def fuzz(client: TestClient, published: Published, session: Session) -> None:
    headers = register(client)
    valid = walk(published.publication, [0, 1, 2, 2, 1, 0, 0, 2])

    @settings(
        max_examples=150,
        deadline=None,
        suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
    )
    @given(body=uploads(published.publication_id, valid))
    def check(body: Any) -> None:
        before = row_counts(session)
        reply = client.post("/api/traces", content=json.dumps(body), headers=headers)
        assert reply.status_code < 500, reply.text
        assert "error" in reply.json() or reply.status_code in (200, 201)
        traces, steps, declared = row_counts(session)
        assert steps == declared  # every stored trace has all of its steps
        added = traces - before[0]
        assert added == (1 if reply.status_code == 201 else 0)

    check()
