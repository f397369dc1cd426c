"""Artifact files damaged as bit rot damages them, for the tests of reading them back."""

from __future__ import annotations

import os
from pathlib import Path


def flip_in_place(path: Path, at: int) -> bytes:
    """Flip one bit of the byte at ``at`` (negative from the end) where the file lies, its
    size, inode and modification time kept: nothing but its bytes tells it changed.
    Returns the file's new bytes."""
    before = path.stat()
    with path.open("r+b") as file:
        file.seek(at, os.SEEK_SET if at >= 0 else os.SEEK_END)
        where = file.tell()
        byte = file.read(1)[0]
        file.seek(where)
        file.write(bytes([byte ^ 0x10]))
    os.utime(path, ns=(before.st_atime_ns, before.st_mtime_ns))
    after = path.stat()
    kept = (after.st_size, after.st_ino, after.st_mtime_ns)
    assert kept == (before.st_size, before.st_ino, before.st_mtime_ns)
    return path.read_bytes()
