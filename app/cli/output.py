"""What every ``srg`` command prints: progress on stderr, results on stdout, errors in one line.

The rule of ``--json``: a command prints a short human form of its result (a table, its
figures rounded) unless given ``--json``, which prints the machine-readable JSON result on
stdout instead, every figure in full. A command that also writes its result to a file
takes the path as ``--result PATH``. Benchmarks always print JSON and take no ``--json``.

Errors: an :class:`~app.core.errors.SrgError` (the user can act on it) and the library
errors mapped below (a setting pydantic refused, a database that cannot be used, a server
that cannot be reached, a module of an extra not installed: :mod:`app.cli.extras`) end the
command with one ``srg: error: ...`` line on stderr and exit status 2. Any other exception
is a bug and keeps its traceback.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import asdict, is_dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer

from app.cli.extras import missing_extra_message
from app.core.errors import SrgError

if TYPE_CHECKING:
    from sqlalchemy.exc import DBAPIError

#: how ``--json`` is declared by every command that has it
JSON_HELP = "print the JSON result instead of the human form"


@contextmanager
def progress_bar(total: int, label: str) -> Iterator[Callable[[int], None]]:
    """A progress bar on stderr; yields the ``advance(n)`` callback services take.

    What it shows stays within 0 and ``total`` (itself at least 0): a service may count
    past its estimate (a frame budget is grown in whole expansions), never below 0. The
    time left is rich's estimate from the recent rate: long runs (an experiment takes
    hours) say when they will end.
    """
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    total = max(total, 0)
    done = 0
    columns = (
        TextColumn(label),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        TextColumn("left"),
        TimeRemainingColumn(),
    )
    with Progress(*columns, console=Console(stderr=True), transient=False) as bar:
        task = bar.add_task(label, total=total)

        def advance(n: int) -> None:
            nonlocal done
            done = min(max(done + n, 0), total)
            bar.update(task, completed=done)

        yield advance


def _to_json(data: Any) -> str:
    """The JSON text of a result (dates and paths as strings), as scripts read it."""
    return json.dumps(data, indent=2, default=str)


#: a list or mapping of more items shows as its count in a table (``--json`` lists them):
#: 53 corrupt digests would otherwise be a wall of hashes
SHOWN_ITEMS = 3
#: significant digits of a measured figure in a table (``--json`` prints every digit)
SHOWN_DIGITS = 4


def emit(result: Any, as_json: bool, title: str | None = None) -> None:
    """Print a result (a dataclass, a dict; a list with ``as_json``): its JSON, or a table
    of its figures, one a row, under ``title``."""
    data = asdict(result) if is_dataclass(result) and not isinstance(result, type) else result
    if as_json:
        typer.echo(_to_json(data))
        return
    from rich import box
    from rich.console import Console
    from rich.table import Table
    from rich.text import Text

    table = Table(title=None if title is None else Text(title), box=box.SIMPLE_HEAD)
    table.add_column("figure")
    table.add_column("value", overflow="fold")
    for key, value in data.items():  # Text: a name in brackets is no markup
        table.add_row(Text(key.replace("_", " ")), Text(_cell(value)))
    Console().print(table)


def emit_measured(result: Any) -> None:
    """A benchmark's JSON on stdout, led by where and how it was measured."""
    from app.config import get_settings
    from app.reports.provenance import with_provenance

    emit(with_provenance(result, get_settings()), as_json=True)


def _cell(value: Any) -> str:
    """A value as a table shows it: measured figures rounded, long collections counted."""
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        if abs(value) >= 10**SHOWN_DIGITS:  # whole units, never 1.235e+05
            return f"{value:.0f}"
        return f"{value:.{SHOWN_DIGITS}g}"
    if isinstance(value, list | tuple | set | dict):
        if not value:
            return "none"
        if len(value) > SHOWN_ITEMS:
            return f"{len(value)} items (--json lists them)"
        if isinstance(value, dict):
            return ", ".join(f"{k}: {_cell(v)}" for k, v in value.items())
        return ", ".join(_cell(v) for v in value)
    return str(value)


def write_result(path: Path, data: Any) -> None:
    """Write a result as JSON to the file of ``--result``, its directory made."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(_to_json(data) + "\n")


@contextmanager
def user_errors_in_one_line() -> Iterator[None]:
    """Turn the errors a user can act on into one ``srg: error:`` line and exit 2."""
    try:
        yield
    except SystemExit:
        raise
    except Exception as exc:
        if _is_click(exc, "UsageError"):  # typer would draw a box of five lines around it
            ctx = getattr(exc, "ctx", None)
            hint = f" (see {ctx.command_path} --help)" if ctx is not None else ""
            message = getattr(exc, "format_message", exc.__str__)()
            # typer checks a choice with pydantic, which leads its reason with this
            message = message.replace(": Value error, ", ": ")
            typer.echo(f"srg: error: {message}{hint}".splitlines()[0], err=True)
            sys.exit(2)
        if _is_click(exc, "Abort"):
            typer.echo("srg: aborted", err=True)
            sys.exit(1)
        message = user_error_message(exc)
        if message is None:
            raise
        typer.echo(f"srg: error: {message}".splitlines()[0], err=True)
        sys.exit(2)


def _is_click(exc: Exception, name: str) -> bool:
    """Whether ``exc`` is click's ``name`` exception: by class name along its MRO, because
    typer ships its own copy of click (``typer._click``), not the ``click`` package."""
    return any(cls.__name__ == name for cls in type(exc).__mro__)


def user_error_message(exc: Exception) -> str | None:
    """What ``exc`` tells the user, when it is theirs to act on; ``None`` for a bug."""
    from pydantic import ValidationError
    from sqlalchemy.exc import DBAPIError, OperationalError

    from app.config import SETTINGS_CLASSES

    if isinstance(exc, SrgError):
        return str(exc.args[0] if exc.args else exc)
    missing = missing_extra_message(exc)
    if missing is not None:
        return missing
    if isinstance(exc, ValidationError) and exc.title in SETTINGS_CLASSES:
        # a field's variable is named for the field alone, whatever group holds it
        return "; ".join(
            f"SRG_{str(error['loc'][-1]).upper()}: {error['msg']}" for error in exc.errors()
        )
    if isinstance(exc, DBAPIError):
        mapped = database_user_error(exc)
        if mapped is not None:
            return mapped
        if isinstance(exc, OperationalError):
            return f"cannot use the database: {exc.orig}"
        return None
    # httpx not loaded: the error is none of its own (and without the 'api' extra it is absent)
    httpx = sys.modules.get("httpx")
    if httpx is not None and isinstance(exc, httpx.TransportError):
        return f"cannot reach the server: {exc}"
    if isinstance(exc, OSError) and exc.strerror:  # the machine's: a path, a disk, a port
        return f"{exc.filename}: {exc.strerror}" if exc.filename else exc.strerror
    return None


def database_user_error(exc: DBAPIError) -> str | None:
    """What a database error means to the user, when it is theirs to fix; else ``None``.

    A database that cannot serve (never upgraded, unreachable, not a database, damaged,
    locked: :func:`app.db.errors.database_unavailable`) is; a constraint violated or a wrong
    statement is a bug and keeps its traceback.
    """
    from app.config import get_settings
    from app.db.engines import parse_database_url
    from app.db.errors import database_unavailable

    url = parse_database_url(get_settings().resolved_database_url)
    unavailable = database_unavailable(exc, url)
    return None if unavailable is None else str(unavailable)
