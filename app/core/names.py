"""The one rule for the names users give graphs and experiments.

A name travels: it is a column (of a bounded length on PostgreSQL, where SQLite would
store any length), a path segment of the API (``/api/graphs/{name}``, where ``/`` can
never be served and ``.`` or ``..`` are folded away by clients), a directory under
``var`` (an experiment's report) and a word on a shell's command line. So it is
checked once, the same way on every backend, before anything is written: ASCII letters,
digits, ``.``, ``_`` and ``-``, starting with a letter or a digit, not all digits
(digits name a row by its id), and no longer than its column.
"""

from __future__ import annotations

import re

from app.core.errors import InvalidInput

_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]*")
_DIGITS = re.compile(r"[0-9]+")


class InvalidName(InvalidInput):
    """A name that breaks the rule above; the message says which part."""


def check_name(name: str, *, what: str, max_length: int) -> str:
    """``name`` itself if it follows the rule; else :class:`InvalidName` (one line).

    ``what`` says whose name it is in the message ("graph", "experiment");
    ``max_length`` is the length of its column (or less, where derived names need room).
    """
    shown = name if len(name) <= 40 else f"{name[:37]}..."
    if not name:
        raise InvalidName(f"a {what} name cannot be empty")
    if len(name) > max_length:
        raise InvalidName(
            f"a {what} name has at most {max_length} characters, got {len(name)} ({shown!r})"
        )
    if _DIGITS.fullmatch(name):
        raise InvalidName(f"a {what} name cannot be all digits (ids are), got {shown!r}")
    if not _NAME.fullmatch(name):
        raise InvalidName(
            f"a {what} name takes ASCII letters, digits, '.', '_' and '-' and starts with a "
            f"letter or a digit (no '/', no spaces), got {shown!r}"
        )
    return name
