"""How a long service reports its work as it goes.

A service that takes minutes (growing, rendering, building an initial tree) takes an
``advance(n)`` callback and calls it after each n more units (frames, clips,
animations); the CLI draws it as a bar (``app.cli.output.progress_bar``), the
experiment's pool counts from the database instead.
"""

from __future__ import annotations

from collections.abc import Callable

#: ``advance(n)``: n more units of the work done
Advance = Callable[[int], None]
