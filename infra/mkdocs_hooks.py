"""MkDocs hooks (mkdocs.yml): the commands and configuration pages, generated from the
code at every build (app/cli/reference.py), so that they cannot drift from it."""

from __future__ import annotations

from typing import Any

from mkdocs.structure.files import File, Files

from app.cli.reference import (
    COMMANDS_PAGE,
    CONFIGURATION_PAGE,
    commands_markdown,
    settings_markdown,
)


def on_files(files: Files, config: Any) -> Files:
    """Add the generated pages to the site's files, as if they were in docs/."""
    for page, content in (
        (COMMANDS_PAGE, commands_markdown()),
        (CONFIGURATION_PAGE, settings_markdown()),
    ):
        files.append(File.generated(config, page, content=content))
    return files
