"""The tables page of the docs site, written from the tables' own comments at build time
(``infra/mkdocs_hooks.py``): what a column means is said once, in the schema, where
``psql``'s ``\\d+`` and SQLite readers see it too (docs/analytics.md)."""

from __future__ import annotations

from sqlalchemy import MetaData, Table

#: the page this module writes, by its path under docs/
TABLES_PAGE = "tables.md"


def tables_markdown(metadata: MetaData) -> str:
    """An entity diagram of how the tables refer to each other, then per table its
    comment and its columns with their types and comments."""
    tables = metadata.sorted_tables
    lines = [
        "# Tables",
        "",
        "Every table srg stores, as its comments in the schema describe it (this page is "
        "generated from them, `app/models/reference.py`, each time the site is built). "
        "The views and the questions they answer: [Analytics in SQL](analytics.md).",
        "",
        "```mermaid",
        "erDiagram",
    ]
    for table in tables:
        for target in sorted({fk.column.table.name for fk in table.foreign_keys}):
            if target != table.name:
                lines.append(f"    {target} ||--o{{ {table.name} : has")
    lines += ["```", ""]
    for table in tables:
        lines += _table_section(table)
    return "\n".join(lines) + "\n"


def _table_section(table: Table) -> list[str]:
    lines = [f"## `{table.name}`", "", table.comment or "", ""]
    lines += ["| column | type | refers to | meaning |", "|---|---|---|---|"]
    for column in table.columns:
        refers = ", ".join(f"`{fk.target_fullname}`" for fk in column.foreign_keys)
        key = " (key)" if column.primary_key else ""
        meaning = (column.comment or "").replace("|", "\\|").replace("\n", " ")
        lines.append(f"| `{column.name}`{key} | {column.type} | {refers} | {meaning} |")
    return [*lines, ""]
