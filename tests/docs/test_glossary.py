"""The glossary (docs/glossary.md) defines every term of srg's own that the README uses
to explain the product, so a newcomer who meets one there can look it up."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
#: srg's own words in the README, as the glossary's entries begin
README_TERMS = [
    "Artifact", "Baseline", "Blend", "Bot", "Calibration", "Checkpoint", "Clip", "Control",
    "Crowd", "Dynamics", "Epoch", "Fluid", "Judge", "Player model", "Session", "sr-crowd",
    "STATERANK", "State graph", "Trace", "Visibly wrong", "World",
]  # fmt: skip


def test_every_term_the_readme_uses_has_an_entry() -> None:
    readme = (ROOT / "README.md").read_text().lower()
    entries = re.findall(r"^\*\*([^*]+?)\.\*\*", (ROOT / "docs/glossary.md").read_text(), re.M)
    defined = {name.strip().lower() for entry in entries for name in entry.split(",")}
    for term in README_TERMS:
        assert term.lower() in readme, f"{term!r} is no longer in the README: drop it here"
        assert term.lower() in defined, f"the glossary has no entry for {term!r}"


def test_the_entries_are_in_alphabetical_order() -> None:
    entries = re.findall(r"^\*\*([^*]+?)\.\*\*", (ROOT / "docs/glossary.md").read_text(), re.M)
    assert len(entries) >= len(README_TERMS)
    assert entries == sorted(entries, key=str.lower)
