"""The commands and configuration references of the docs site, written from the code.

A hand-written table of options drifts (six options of ``srg experiment`` were once
missing from one); these pages are made from what ``srg --help`` itself shows (Typer's
help texts of every command, argument and option) and from the field descriptions and
bounds of :mod:`app.config`, when ``mkdocs build`` runs (``infra/mkdocs_hooks.py``). So
the site cannot say what the code does not do.
"""

from __future__ import annotations

import enum
import typing
from collections.abc import Iterator
from typing import Any

import annotated_types
from pydantic.fields import FieldInfo
from pydantic_core import PydanticUndefined
from pydantic_settings import BaseSettings

from app.cli.main import click_command
from app.config import Settings

#: the pages this module writes, by their path under docs/
COMMANDS_PAGE, CONFIGURATION_PAGE = "commands.md", "configuration.md"


def root_command() -> Any:
    """The click command of ``srg``, as the console script builds it (Typer's own click
    classes, hence ``Any``: Typer ships its own copy of click)."""
    return click_command()


def walk_commands(command: Any, path: tuple[str, ...] = ("srg",)) -> Iterator[tuple[str, Any]]:
    """``(command path, command)`` of ``command`` and every command under it, in the
    order ``--help`` lists them; hidden ones left out."""
    yield " ".join(path), command
    ctx = command.make_context(path[-1], [], resilient_parsing=True)
    for name in getattr(command, "list_commands", lambda _ctx: [])(ctx):
        sub = command.get_command(ctx, name)
        if sub is not None and not sub.hidden:
            yield from walk_commands(sub, (*path, name))


def commands_markdown() -> str:
    """The commands page: per command its help text and a table of what it takes."""
    root = root_command()
    lines = [
        "# Commands",
        "",
        "Every `srg` command with its arguments and options, as `srg COMMAND --help` "
        "prints them. This page is generated from the code (`app/cli/reference.py`) each "
        "time the site is built, so it cannot drift from the command line. How commands "
        "print, fail and check a database: [Reference](reference.md#commands).",
    ]
    for path, command in walk_commands(root):
        lines += ["", f"## `{path}`", "", f"`{_usage(path, command)}`", ""]
        lines += [_help_text(command.help or ""), ""]
        rows = _parameter_rows(command, path)
        if rows:
            lines += ["| argument or option | what it is |", "|---|---|", *rows]
        if hasattr(command, "commands"):
            lines += ["", "Commands: " + ", ".join(f"`{path} {n}`" for n in command.commands)]
    return "\n".join(lines) + "\n"


def _usage(path: str, command: Any) -> str:
    ctx = command.make_context(path.split()[-1], [], resilient_parsing=True)
    pieces = [
        piece.upper().strip("{}") if piece.startswith("{") else piece
        for piece in command.collect_usage_pieces(ctx)
    ]
    return " ".join([path, *pieces])


def _help_text(text: str) -> str:
    """A docstring's paragraphs as Markdown: reST's double backticks as code spans."""
    return text.replace("``", "`").replace("\b\n", "").strip()


def _parameter_rows(command: Any, path: str) -> list[str]:
    ctx = command.make_context(path.split()[-1], [], resilient_parsing=True)
    rows = []
    for parameter in command.get_params(ctx):
        record = parameter.get_help_record(ctx)
        if record is None:
            continue
        names, description = record
        rows.append(f"| `{_one_line(names)}` | {_cell(_help_text(description))} |")
    return rows


def _one_line(text: str) -> str:
    """Text on one line (a code span in a table cell: Markdown keeps its pipes)."""
    return " ".join(text.split())


def _cell(text: str) -> str:
    """Prose safe in one Markdown table cell: on one line, pipes escaped, no HTML."""
    return _one_line(text).replace("|", "\\|").replace("<", "&lt;")


def settings_markdown() -> str:
    """The configuration page: one table per settings group, each variable with its
    default, its bounds or choices and its description."""
    lines = [
        "# Configuration",
        "",
        "Every `SRG_*` environment variable (or line of `.env`) that srg reads, with its "
        "default, the values it accepts and what it does. This page is generated from "
        "`app/config.py` each time the site is built, so it cannot drift from the code. "
        "How the settings are read and refused: [Reference](reference.md#configuration).",
    ]
    groups = {name: f.annotation for name, f in Settings.model_fields.items() if _is_group(f)}
    top = {name: f for name, f in Settings.model_fields.items() if name not in groups}
    lines += _settings_table("Where the data lives and what carries the work", Settings, top)
    for name, group in groups.items():
        assert isinstance(group, type) and issubclass(group, BaseSettings)
        title = f"{_first_sentence(group.__doc__ or name)} (`settings.{name}`)"
        lines += _settings_table(title, group, group.model_fields)
    return "\n".join(lines) + "\n"


def _is_group(field: FieldInfo) -> bool:
    return isinstance(field.annotation, type) and issubclass(field.annotation, BaseSettings)


def _first_sentence(docstring: str) -> str:
    """The docstring's opening clause: "How a graph grows" of "How a graph grows: ..."."""
    return " ".join(docstring.split()).split(". ")[0].split(":")[0].split(" (")[0].rstrip(".")


def _settings_table(
    title: str, model: type[BaseSettings], fields: dict[str, FieldInfo]
) -> list[str]:
    prefix = str(model.model_config.get("env_prefix", ""))
    lines = [
        "",
        f"## {title}",
        "",
        "| variable | default | accepts | meaning |",
        "|---|---|---|---|",
    ]
    for name, field in fields.items():
        variables = [f"{prefix}{name}".upper()]
        alias = field.validation_alias
        if alias is not None and hasattr(alias, "choices"):
            variables = [str(choice) for choice in alias.choices]
        names = " or ".join(f"`{variable}`" for variable in variables)
        default = _default(field)
        lines.append(
            f"| {names} | {default} | {_cell(_accepts(field))} | "
            f"{_cell(_help_text(field.description or ''))} |"
        )
    return lines


def _default(field: FieldInfo) -> str:
    if field.default is PydanticUndefined:
        return ""
    value = field.default.value if isinstance(field.default, enum.Enum) else field.default
    if isinstance(value, bool):
        return f"`{str(value).lower()}`"
    return "empty" if value in ("", None) else f"`{_one_line(str(value))}`"


def _accepts(field: FieldInfo) -> str:
    """The bounds or the choices pydantic checks, in words."""
    annotation = field.annotation
    if typing.get_origin(annotation) is typing.Literal:
        return ", ".join(str(choice) for choice in typing.get_args(annotation))
    if isinstance(annotation, type) and issubclass(annotation, enum.Enum):
        return ", ".join(str(member.value) for member in annotation)
    bounds = (
        (annotated_types.Ge, ">=", "ge"),
        (annotated_types.Gt, ">", "gt"),
        (annotated_types.Le, "<=", "le"),
        (annotated_types.Lt, "<", "lt"),
    )
    words = [
        f"{sign} {_number(getattr(constraint, attribute))}"
        for constraint in field.metadata
        for kind, sign, attribute in bounds
        if isinstance(constraint, kind)
    ]
    return ", ".join([_KINDS.get(str(annotation), str(annotation)), *words])


#: how a field's type reads in the table
_KINDS = {
    "<class 'str'>": "text",
    "<class 'int'>": "integer",
    "<class 'float'>": "number",
    "<class 'bool'>": "true or false",
    "<class 'pathlib.Path'>": "path",
    "pathlib.Path | None": "path",
}


def _number(value: object) -> str:
    """A bound as a person reads it: 604800, not 604800.0; 1e-06 as written."""
    if isinstance(value, float) and value.is_integer():
        return f"{int(value):,}"
    return f"{value:,}" if isinstance(value, int) else str(value)
