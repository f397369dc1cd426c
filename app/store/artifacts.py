"""A content-addressed file store for bulk arrays and animations.

Files live under ``root/ab/cd/abcd...`` (sha256 of the bytes, two-level fan-out so no
directory grows huge) and are written to a temporary file then renamed, so a reader
never sees half a file and a retried or concurrent write of the same content is a no-op.
Each file is registered in the ``artifacts`` table in the caller's transaction; a file
whose transaction rolled back is harmless garbage, never a dangling reference.

Arrays are stored in the compressed format of :mod:`app.store.array_codec`, whose bytes
are a function of the arrays alone, so equal arrays give equal bytes and hence the same
hash. Artifacts written before it are ``.npz`` zip files; :meth:`ArtifactStore.get_arrays`
reads both, telling them apart by their first bytes (a zip's ``PK\\x03\\x04``, the codec's
``MAGIC``).

Every read is checked against the hash that names the file (docs/runtime.md, "Artifacts
verified on read"): a file whose bytes do not hash to its name is moved aside under
``root/corrupt/`` and the read raises :class:`ArtifactCorrupt`, so a flipped bit is never
decoded into a graph nor served. Nothing remembers a file as verified: a byte flipped in
place keeps the file's size, inode and modification time, so only its hash can tell, and
hashing costs little beside decoding or sending the bytes. The error's message names the
digest alone (it reaches API clients and growth polls); the log names the file.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import logging
import os
import tempfile
from collections.abc import Iterable, Mapping
from concurrent.futures import ThreadPoolExecutor
from itertools import islice
from pathlib import Path

import numpy as np
from sqlalchemy.orm import Session

from app.core.errors import NotFound, Unavailable
from app.models import Artifact
from app.store._sql import insert_ignoring_duplicates
from app.store.array_codec import ARRAYS_MEDIA_TYPE, decode_arrays, encode_arrays

#: the first bytes of a zip file: an ``.npz`` artifact of the format before the codec's
ZIP_MAGIC = b"PK\x03\x04"
WRITER_THREADS = 8
WRITE_CHUNK = 512
#: where files that failed their hash check are moved, under the store's root
CORRUPT_DIR = "corrupt"

log = logging.getLogger(__name__)


class ArtifactNotFound(NotFound):
    """No file with that hash in the artifact store."""


class ArtifactCorrupt(Unavailable):
    """A stored file's bytes do not match its hash: it was moved aside, not used
    (``srg fsck --repair`` recomputes what can be recomputed)."""


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

    def corrupt_path(self, digest: str) -> Path:
        """Where the file of ``digest`` goes once it fails its hash check."""
        return self.root / CORRUPT_DIR / digest

    def get_bytes(self, digest: str) -> bytes:
        """The bytes of ``digest``, checked against it (:class:`ArtifactCorrupt` if not).

        What is checked is what is returned: a caller that serves these bytes under the
        digest (an ``immutable`` response) serves bytes that matched it.
        """
        try:
            data = self.path_for(digest).read_bytes()
        except FileNotFoundError:
            # gone since this instance wrote it (moved aside by another process's read):
            # a later put must write it again, not trust the memory
            self._written.discard(digest)
            raise self._missing(digest) from None
        if hashlib.sha256(data).hexdigest() != digest:
            self._move_aside(digest)
            raise self._corrupt(digest)
        return data

    def put_arrays(self, arrays: Mapping[str, np.ndarray], *, session: Session) -> str:
        return self.put_bytes(encode_arrays(arrays), media_type=ARRAYS_MEDIA_TYPE, session=session)

    def get_arrays(self, digest: str, names: Iterable[str] | None = None) -> dict[str, np.ndarray]:
        """The arrays of an arrays artifact; with ``names``, only those members are decoded."""
        data = self.get_bytes(digest)
        if not data.startswith(ZIP_MAGIC):
            return decode_arrays(data, names)
        with np.load(io.BytesIO(data), allow_pickle=False) as npz:
            return {name: npz[name] for name in (npz.files if names is None else names)}

    def _move_aside(self, digest: str) -> None:
        """Take a corrupt file out of the store; a later put of the true bytes heals it."""
        aside = self.corrupt_path(digest)
        aside.parent.mkdir(parents=True, exist_ok=True)
        self._written.discard(digest)
        with contextlib.suppress(FileNotFoundError):  # another reader moved it first
            os.replace(self.path_for(digest), aside)

    def _missing(self, digest: str) -> ArtifactNotFound | ArtifactCorrupt:
        if self.corrupt_path(digest).exists():
            return self._corrupt(digest)
        return ArtifactNotFound(f"no artifact {digest} in the artifact store")

    def _corrupt(self, digest: str) -> ArtifactCorrupt:
        aside = self.corrupt_path(digest)
        log.warning("artifact %s does not match its hash; its file is %s", digest, aside)
        return ArtifactCorrupt(
            f"artifact {digest} does not match its hash; it was moved to {CORRUPT_DIR}/ "
            "in the artifact directory (run srg fsck --repair)"
        )

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
