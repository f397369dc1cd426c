"""A content-addressed file store for bulk arrays and animations.

Files live under ``root/ab/cd/abcd...`` (sha256 of the bytes, two-level fan-out so no
directory grows huge) and are written to a temporary file then renamed, so a reader
never sees half a file and a retried or concurrent write of the same content is a no-op.
Each file is registered in the ``artifacts`` table in the caller's transaction; a file
whose transaction rolled back is harmless garbage, never a dangling reference.

Arrays are stored as ``.npz`` written with fixed zip timestamps, so equal arrays give
equal bytes and hence the same hash.
"""

from __future__ import annotations

import hashlib
import os
import struct
import tempfile
import zlib
from collections.abc import Iterable, Mapping
from concurrent.futures import ThreadPoolExecutor
from itertools import islice
from pathlib import Path

import numpy as np
from sqlalchemy.orm import Session

from app.models import Artifact
from app.store._sql import insert_ignoring_duplicates

NPZ_MEDIA_TYPE = "application/x-npz"
#: zip's DOS time and date of 1980-01-01 00:00, so equal arrays give equal bytes
_ZIP_EPOCH_DOS = (0, (1 << 5) | 1)
_ZIP_LIMIT = 0xFFFFFFFF
WRITER_THREADS = 8
_NPY_MAGIC = b"\x93NUMPY\x01\x00"
WRITE_CHUNK = 512


class ArtifactNotFound(LookupError):
    """No file with that hash in the artifact store."""


class ArtifactStore:
    def __init__(self, root: Path) -> None:
        self.root = Path(root)
        # what this instance already wrote or found: repeated content costs no syscall
        self._directories: set[Path] = set()
        self._written: set[str] = set()

    def path_for(self, digest: str) -> Path:
        return self.root / digest[:2] / digest[2:4] / digest

    def put_bytes(self, data: bytes, *, media_type: str, session: Session) -> str:
        """Store ``data`` (idempotent) and return its sha256 hex digest."""
        return self.put_many([data], media_type=media_type, session=session)[0]

    def put_many(self, blobs: Iterable[bytes], *, media_type: str, session: Session) -> list[str]:
        """Store several blobs and register them with one bulk insert.

        ``blobs`` is consumed lazily, a chunk at a time, and each chunk is written by a
        few threads: creating many small files is bound by filesystem latency, not CPU.
        """
        digests: list[str] = []
        rows: dict[str, dict[str, object]] = {}
        remaining = iter(blobs)
        with ThreadPoolExecutor(max_workers=WRITER_THREADS) as pool:
            while chunk := list(islice(remaining, WRITE_CHUNK)):
                for digest, data in zip(pool.map(self._write, chunk), chunk, strict=True):
                    digests.append(digest)
                    rows[digest] = {"hash": digest, "size": len(data), "media_type": media_type}
        insert_ignoring_duplicates(session, Artifact, list(rows.values()))
        return digests

    def get_bytes(self, digest: str) -> bytes:
        try:
            return self.path_for(digest).read_bytes()
        except FileNotFoundError:
            raise ArtifactNotFound(f"no artifact {digest} under {self.root}") from None

    def put_arrays(self, arrays: Mapping[str, np.ndarray], *, session: Session) -> str:
        return self.put_bytes(encode_arrays(arrays), media_type=NPZ_MEDIA_TYPE, session=session)

    def get_arrays(self, digest: str, names: Iterable[str] | None = None) -> dict[str, np.ndarray]:
        """The arrays of an ``.npz`` artifact; with ``names``, only those members are read."""
        try:
            npz = np.load(self.path_for(digest), allow_pickle=False)
        except FileNotFoundError:
            raise ArtifactNotFound(f"no artifact {digest} under {self.root}") from None
        with npz:
            return {name: npz[name] for name in (npz.files if names is None else names)}

    def _write(self, data: bytes) -> str:
        digest = hashlib.sha256(data).hexdigest()
        path = self.path_for(digest)
        if digest in self._written or _touch(path):
            self._written.add(digest)
            return digest
        if path.parent not in self._directories:
            path.parent.mkdir(parents=True, exist_ok=True)
            self._directories.add(path.parent)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-")
        try:
            with os.fdopen(fd, "wb") as out:
                out.write(data)
            os.replace(tmp, path)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
        self._written.add(digest)
        return digest


def _touch(path: Path) -> bool:
    """Whether ``path`` exists; if so its mtime becomes now.

    Storing content that is already there marks it as in use, so a collection of orphaned
    artifacts (:mod:`app.store.artifact_gc`, which keeps recent files) cannot remove a file
    that a running step is about to reference again.
    """
    try:
        os.utime(path)
    except FileNotFoundError:
        return False
    except OSError:  # not ours to touch (a read-only store): it exists all the same
        return path.exists()
    return True


def encode_arrays(arrays: Mapping[str, np.ndarray]) -> bytes:
    """Deterministic ``.npz`` bytes: a stored (uncompressed) zip of ``.npy`` members.

    Written by hand because ``zipfile`` costs ~100 us per member, which dominated saving
    a large graph's bundles; the layout is plain zip (no zip64: members < 4 GiB), so
    ``np.load`` and ``zipfile`` read it. Float fields barely compress, hence no deflate.
    """
    local, central = bytearray(), bytearray()
    for name in sorted(arrays):
        data = _npy_bytes(np.asarray(arrays[name]))
        filename = f"{name}.npy".encode()
        if len(data) >= _ZIP_LIMIT or len(local) >= _ZIP_LIMIT:
            raise ValueError(f"array {name!r} is too large for an artifact bundle")
        fields = (20, 0, 0, *_ZIP_EPOCH_DOS, zlib.crc32(data), len(data), len(data))
        offset = len(local)
        local += struct.pack("<4s5H3L2H", b"PK\x03\x04", *fields, len(filename), 0)
        local += filename + data
        central += struct.pack(
            "<4s6H3L5HLL", b"PK\x01\x02", 20, *fields, len(filename), 0, 0, 0, 0, 0, offset
        )
        central += filename
    count = len(arrays)
    end = struct.pack("<4s4H2LH", b"PK\x05\x06", 0, 0, count, count, len(central), len(local), 0)
    return bytes(local + central + end)


def _npy_bytes(array: np.ndarray) -> bytes:
    """An ``.npy`` file (format 1.0) in one piece; numpy's writer streams and is slow here."""
    if array.dtype.hasobject:
        raise TypeError("object arrays cannot be stored as artifacts")
    array = array if array.flags.c_contiguous else array.copy(order="C")
    descr = np.lib.format.dtype_to_descr(array.dtype)
    header = f"{{'descr': {descr!r}, 'fortran_order': False, 'shape': {array.shape!r}, }}"
    # magic (6) + version (2) + length (2) + header + newline, padded to 64 bytes
    padding = -(10 + len(header) + 1) % 64
    encoded = (header + " " * padding + "\n").encode("latin1")
    return _NPY_MAGIC + len(encoded).to_bytes(2, "little") + encoded + array.tobytes()
