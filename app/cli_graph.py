"""``srg db``, ``init``, ``grow``, ``publish``, ``play``, ``status``: persisted graphs."""

from __future__ import annotations

import typer


def register_graph_commands(app: typer.Typer) -> None:
    """Attach the graph commands to the main app."""
