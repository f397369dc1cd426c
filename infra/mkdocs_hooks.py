"""MkDocs hooks (mkdocs.yml): the commands, configuration, HTTP API and tables pages,
generated from the code at every build (app/cli/reference.py, app/api/reference.py,
app/models/reference.py), so that they cannot drift from it; and links into
``studies/``, the dated studies kept beside the manual but outside the site."""

from __future__ import annotations

import re
from pathlib import Path, PurePosixPath
from typing import Any

from mkdocs.exceptions import PluginError
from mkdocs.structure.files import File, Files
from mkdocs.structure.pages import Page

from app.api.app import create_app
from app.api.reference import API_PAGE, api_markdown
from app.cli.reference import (
    COMMANDS_PAGE,
    CONFIGURATION_PAGE,
    commands_markdown,
    settings_markdown,
)
from app.config import Settings
from app.models import Base
from app.models.reference import TABLES_PAGE, tables_markdown

ROOT = Path(__file__).resolve().parents[1]
STUDIES = ROOT / "studies"
#: a Markdown link whose target climbs out of docs/ into studies/
STUDY_LINK = re.compile(r"\[([^\]]+)\]\(((?:\.\./)+studies/[^)#\s]*)(#[^)\s]*)?\)")


def on_files(files: Files, config: Any) -> Files:
    """Add the generated pages to the site's files, as if they were in docs/."""
    for page, content in (
        (COMMANDS_PAGE, commands_markdown()),
        (CONFIGURATION_PAGE, settings_markdown()),
        (API_PAGE, api_markdown(create_app(Settings()).openapi())),
        (TABLES_PAGE, tables_markdown(Base.metadata)),
    ):
        files.append(File.generated(config, page, content=content))
    return files


def on_page_markdown(markdown: str, page: Page, config: Any, files: Files) -> str:
    """A link into ``studies/`` reads on GitHub as a link; in the site, which holds none of
    the studies' bulk, it becomes the repository path it names. A path that names nothing
    fails the build, as a broken link inside the site does."""
    folder = (Path(config["docs_dir"]) / page.file.src_path).parent

    def as_path(link: re.Match[str]) -> str:
        label, target = link.group(1), link.group(2)
        found = (folder / target).resolve()
        if STUDIES not in (found, *found.parents) or not found.exists():
            raise PluginError(f"{page.file.src_path}: {target} is not in studies/")
        path = PurePosixPath(found.relative_to(ROOT)).as_posix()
        return f"`{path}`" if label.strip("`") == path else f"{label} (`{path}`)"

    return STUDY_LINK.sub(as_path, markdown)
