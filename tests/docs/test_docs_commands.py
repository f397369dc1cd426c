"""The README and the docs name only commands and options the CLI has.

Every ``srg ...`` in a code span or a code block of README.md and docs/*.md is read the
way a shell would and walked down the click command tree of ``srg``: an unknown command
or an unknown ``--option`` of the command named fails, as does a shell example whose
value holds a ``|`` (pasted into a shell it is a pipe). The per-run reports under
studies/*/ keep the commands they were run with and are not read. The generated
pages (app/cli/reference.py) are checked to name every command, option and setting.
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path
from typing import Any

import pytest

from app.cli.reference import commands_markdown, root_command, settings_markdown, walk_commands
from app.config import Settings

ROOT = Path(__file__).resolve().parents[2]
PAGES = [
    ROOT / "README.md",
    *sorted((ROOT / "docs").glob("*.md")),
    ROOT / "studies/history.md",
]
FENCED = re.compile(r"^```[^\n]*\n(.*?)^```", re.MULTILINE | re.DOTALL)
INLINE = re.compile(r"`([^`]+)`")
#: where a command line ends: a pipe, a list, a redirection, a comment
STOPS = re.compile(r"^(\|\|?|&&?|;|>.*|2>.*|<|#.*|\))$")
#: a word that stands for something: NAME, ARGS..., <command>, ...
#: the command tree, built once: every snippet is walked down it
SRG = root_command()
PLACEHOLDER = re.compile(r"^(\.\.\.|<[^>]*>|[A-Z][A-Z0-9_.-]*(\.\.\.)?)$")


def snippets(text: str) -> list[tuple[str, bool]]:
    """(code, is it a shell block) of every fenced block (one per line) and code span."""
    blocks = [block.replace("\\\n", " ") for block in FENCED.findall(text)]  # continued lines
    found = [(line, True) for block in blocks for line in block.splitlines()]
    prose = FENCED.sub("", text)
    return found + [(" ".join(span.split()), False) for span in INLINE.findall(prose)]


def words(code: str) -> list[str]:
    try:
        return shlex.split(code, comments=True)
    except ValueError:  # an apostrophe in prose: "srg experiment's"
        return code.split()


def invocations(code: str) -> list[list[str]]:
    """The words after each ``srg`` in ``code``, up to where its command line ends."""
    found = []
    tokens = words(code)
    for start, token in enumerate(tokens):
        if token != "srg":
            continue
        rest = []
        for word in tokens[start + 1 :]:
            if STOPS.match(word):
                break
            rest.append(word)
        found.append(rest)
    return found


def problems(rest: list[str], shell: bool) -> list[str]:
    """What is wrong with ``srg`` followed by ``rest``; empty when nothing is."""
    command: Any = SRG
    path = ["srg"]
    while rest and hasattr(command, "commands"):
        word = rest[0].strip("[](),.:;").removesuffix("'s")
        if PLACEHOLDER.match(rest[0]) or not re.match(r"^[a-z]", word):
            return []  # `srg X`, `srg bench ...`, `srg --version`: checked below
        names = word.split("|")
        unknown = [name for name in names if name not in command.commands]
        if unknown:
            return [f"{' '.join(path)} has no command {', '.join(unknown)}"]
        if len(names) > 1:
            return []  # `srg bench rank|sph|clip`: a list of commands in prose
        command = command.commands[word]
        path.append(word)
        rest = rest[1:]
    if command.context_settings.get("ignore_unknown_options"):
        return []  # `srg bench experiment ARGS...` passes its options on
    known = {"--help"} | {
        name
        for parameter in command.params
        for name in (*parameter.opts, *parameter.secondary_opts)
    }
    found = []
    for word in rest:
        for option in word.strip("[](),;").split("|"):
            name = option.split("=")[0].strip("[](),;.")
            if name.startswith("--") and name not in known:
                found.append(f"{' '.join(path)} has no option {name}")
        if shell and "|" in word:
            found.append(f"{' '.join(path)}: {word!r} is a pipe in a shell")
    return found


@pytest.mark.parametrize("page", PAGES, ids=[str(p.relative_to(ROOT)) for p in PAGES])
def test_the_docs_name_only_commands_and_options_the_cli_has(page: Path) -> None:
    found = [
        f"`{code}`: {problem}"
        for code, shell in snippets(page.read_text())
        for rest in invocations(code)
        for problem in problems(rest, shell)
    ]
    assert not found, "\n".join(found)


def test_the_check_catches_an_unknown_command_option_and_pipe() -> None:
    assert problems(["experimnt"], shell=False) == ["srg has no command experimnt"]
    assert problems(["experiment", "--bot", "avoider"], shell=False) == [
        "srg experiment has no option --bot"
    ]
    assert problems(["play", "x", "--bot", "goal-directed|avoider"], shell=True) == [
        "srg play: 'goal-directed|avoider' is a pipe in a shell"
    ]
    assert problems(["bench", "rank|sph|nope"], shell=False) == ["srg bench has no command nope"]
    assert invocations("SRG_X=1 srg worker | tee log") == [["worker"]]
    assert snippets("```bash\nsrg play x \\\n  --bots a\n```\n") == [
        ("srg play x    --bots a", True)
    ]


def test_the_generated_pages_name_every_command_option_and_setting() -> None:
    commands = commands_markdown()
    for path, command in walk_commands(SRG):
        assert f"## `{path}`" in commands
        for parameter in command.params:
            if not parameter.hidden:
                assert all(
                    f"`{name}" in commands for name in parameter.opts if name.startswith("-")
                )
    configuration = settings_markdown()
    for name, field in Settings.model_fields.items():
        group = field.annotation
        fields = group.model_fields if hasattr(group, "model_fields") else {name: field}
        assert all(f"`SRG_{inner.upper()}`" in configuration for inner in fields)
