"""The site's hook for links into studies/ (infra/mkdocs_hooks.py): on GitHub they are
links, in the site the repository path they name, and a path that names nothing fails
the build."""

from __future__ import annotations

import sys
from pathlib import Path
from types import SimpleNamespace

import pytest
from mkdocs.exceptions import PluginError

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "infra"))
from mkdocs_hooks import on_page_markdown  # noqa: E402

CONFIG = {"docs_dir": str(ROOT / "docs")}


def rendered(markdown: str, page: str = "experiment.md") -> str:
    page_object = SimpleNamespace(file=SimpleNamespace(src_path=page))
    return on_page_markdown(markdown, page_object, CONFIG, [])


def test_a_link_into_studies_becomes_its_path() -> None:
    assert rendered("see [the plan](../studies/outside-the-loop/plan.md#1-question).") == (
        "see the plan (`studies/outside-the-loop/plan.md`)."
    )
    assert rendered("[`studies/README.md`](../studies/README.md)") == "`studies/README.md`"


def test_links_inside_the_site_are_left_alone() -> None:
    text = "[design](design.md#runtime) and [a site](https://example.org/studies/x)"
    assert rendered(text) == text


@pytest.mark.parametrize(
    "target", ["../studies/no-such-study/report.md", "../studies/../README.md"]
)
def test_a_link_to_nothing_in_studies_fails_the_build(target: str) -> None:
    with pytest.raises(PluginError, match="is not in studies/"):
        rendered(f"[gone]({target})")
