"""The site's HTTP API and tables pages, generated from the app's OpenAPI document and the
schema's comments (app/api/reference.py, app/models/reference.py): every route and every
column is on them, each said in words."""

from __future__ import annotations

import pytest

from app.api.app import create_app
from app.api.reference import api_markdown
from app.config import Settings
from app.models import Base
from app.models.reference import tables_markdown


@pytest.fixture(scope="module")
def spec() -> dict:
    return create_app(Settings()).openapi()


def test_every_route_is_on_the_api_page_with_words_of_its_own(spec: dict) -> None:
    page = api_markdown(spec)
    routes = {(m.upper(), path) for path, ops in spec["paths"].items() for m in ops}
    assert {("POST", "/api/traces"), ("GET", "/api/health"), ("POST", "/api/players")} <= routes
    assert len(routes) >= 13
    for method, path in routes:
        assert f"## `{method} {path}`" in page
        operation = spec["paths"][path][method.lower()]
        assert operation.get("description"), f"{method} {path} has no docstring"


def test_a_body_is_listed_field_by_field(spec: dict) -> None:
    page = api_markdown(spec)
    section = page.split("## `POST /api/traces`")[1].split("\n## ")[0]
    assert "Body: a JSON `TraceUpload`." in section
    for field in ("publication_id", "idempotency_key", "steps"):
        assert f"| `{field}` |" in section
    assert "| 201 |" in section and "| 409 |" in section


def test_every_table_and_column_is_on_the_tables_page_and_every_reference_drawn() -> None:
    page = tables_markdown(Base.metadata)
    for table in Base.metadata.sorted_tables:
        assert f"## `{table.name}`\n\n{table.comment}" in page
        for column in table.columns:
            assert column.comment, f"{table.name}.{column.name} has no comment"
            assert f"| `{column.name}`" in page
        for key in table.foreign_keys:
            if key.column.table is not table:
                assert f"{key.column.table.name} ||--o{{ {table.name} : has" in page
