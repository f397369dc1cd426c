"""No module of ``app`` over 400 lines: one module, one idea.

A module past that length has grown a second idea that wants its own name (and its
own module), and reading it means scrolling past the first. The limit is checked here,
as the layers are in ``test_layers.py``, so a module that outgrows it fails the suite
with its name and its length instead of waiting for a reviewer to notice.
"""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
MAX_LINES = 400


def modules_over_the_limit(root: Path) -> list[str]:
    """``path (N lines)`` for each module under ``root/app`` longer than :data:`MAX_LINES`."""
    found = []
    for path in sorted((root / "app").rglob("*.py")):
        lines = len(path.read_text().splitlines())
        if lines > MAX_LINES:
            found.append(f"{path.relative_to(root).as_posix()} ({lines} lines)")
    return found


def test_no_module_is_over_the_limit() -> None:
    over = modules_over_the_limit(ROOT)
    assert not over, f"split these modules (over {MAX_LINES} lines): " + ", ".join(over)


def test_a_long_module_is_named(tmp_path: Path) -> None:
    (tmp_path / "app" / "store").mkdir(parents=True)
    (tmp_path / "app" / "store" / "long.py").write_text("x = 1\n" * (MAX_LINES + 1))
    (tmp_path / "app" / "store" / "at_the_limit.py").write_text("x = 1\n" * MAX_LINES)
    assert modules_over_the_limit(tmp_path) == [f"app/store/long.py ({MAX_LINES + 1} lines)"]
