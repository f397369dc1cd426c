"""The HTTP API page of the docs site, written from the app's OpenAPI document at build
time (``infra/mkdocs_hooks.py``), so the manual lists the routes, parameters, bodies and
answers the server has. A running server also serves it browsable at ``/docs``."""

from __future__ import annotations

from typing import Any

#: the page this module writes, by its path under docs/
API_PAGE = "api.md"


def api_markdown(spec: dict[str, Any]) -> str:
    """Per route its description, parameters, body fields and the statuses it answers."""
    lines = [
        "# The HTTP API",
        "",
        "Every route of `srg serve`, generated from its OpenAPI document "
        "(`app/api/reference.py`) each time the site is built. An error is a 4xx or 5xx "
        "with a JSON body; uploads, rate limits and the client that uses these routes: "
        "[Play, the API and traces](play.md). A running server serves the same document "
        "at `/openapi.json`, browsable at `/docs`.",
    ]
    for path, operations in spec["paths"].items():
        for method, operation in operations.items():
            lines += ["", f"## `{method.upper()} {path}`", ""]
            lines += [operation.get("description") or operation["summary"], ""]
            lines += _parameters(operation.get("parameters", []))
            lines += _body(operation.get("requestBody"), spec)
            lines += _responses(operation["responses"])
    return "\n".join(lines) + "\n"


def _cell(text: str) -> str:
    return " ".join(text.split()).replace("|", "\\|")


def _type(schema: dict[str, Any]) -> str:
    if "$ref" in schema:
        return schema["$ref"].rsplit("/", 1)[-1]
    if "anyOf" in schema:
        return " or ".join(_type(s) for s in schema["anyOf"])
    if "prefixItems" in schema:
        return "[" + ", ".join(_type(s) for s in schema["prefixItems"]) + "]"
    if schema.get("type") == "array":
        return f"array of {_type(schema.get('items', {}))}"
    return str(schema.get("type", "any"))


def _parameters(parameters: list[dict[str, Any]]) -> list[str]:
    if not parameters:
        return []
    lines = ["| parameter | in | type | required | meaning |", "|---|---|---|---|---|"]
    for p in parameters:
        schema = p.get("schema", {})
        meaning = _cell(p.get("description") or schema.get("description") or "")
        required = "yes" if p.get("required") else "no"
        lines.append(f"| `{p['name']}` | {p['in']} | {_type(schema)} | {required} | {meaning} |")
    return [*lines, ""]


def _body(body: dict[str, Any] | None, spec: dict[str, Any]) -> list[str]:
    if body is None:
        return []
    schema = next(iter(body["content"].values()))["schema"]
    name = _type(schema) if "$ref" in schema else schema.get("title", "object")
    fields = spec.get("components", {}).get("schemas", {}).get(name, schema)
    required = set(fields.get("required", []))
    lines = [f"Body: a JSON `{name}`.", ""]
    if fields.get("properties"):
        lines += ["| field | type | required | meaning |", "|---|---|---|---|"]
        for field, field_schema in fields["properties"].items():
            meaning = _cell(field_schema.get("description", ""))
            needed = "yes" if field in required else "no"
            lines.append(f"| `{field}` | {_type(field_schema)} | {needed} | {meaning} |")
        lines.append("")
    return lines


def _responses(responses: dict[str, Any]) -> list[str]:
    lines = ["| status | when |", "|---|---|"]
    for status in sorted(responses):
        lines.append(f"| {status} | {_cell(responses[status].get('description', ''))} |")
    return lines
