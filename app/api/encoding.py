"""Conditional and compressed responses: ETags, If-None-Match, gzip for the big JSON,
and the ``Cache-Control`` of what never changes.

The publication JSON is the one large body the API sends, and it never changes once
rendered, so it is compressed once, when rendered, rather than per request; its ETag
is the hash of the uncompressed bytes, weak (``W/``) because the same entity goes out
gzip-encoded or not.
"""

from __future__ import annotations

import gzip
import hashlib
from dataclasses import dataclass

GZIP_LEVEL = 6
#: for a response whose URL names bytes that never change: a clip by its hash, a
#: publication by its id
IMMUTABLE = "public, max-age=31536000, immutable"


@dataclass(frozen=True)
class EncodedJson:
    body: bytes
    gzipped: bytes
    etag: str

    @classmethod
    def of(cls, body: bytes) -> EncodedJson:
        digest = hashlib.sha256(body).hexdigest()
        return cls(body, gzip.compress(body, GZIP_LEVEL, mtime=0), f'W/"{digest}"')


def etag_matches(if_none_match: str, etag: str) -> bool:
    """Whether ``If-None-Match`` names ``etag`` (weak comparison) or is ``*``."""
    wanted = etag.removeprefix("W/")
    for candidate in if_none_match.split(","):
        candidate = candidate.strip()
        if candidate == "*" or candidate.removeprefix("W/") == wanted:
            return True
    return False


def accepts_gzip(accept_encoding: str) -> bool:
    """Whether ``Accept-Encoding`` accepts gzip (listed, or ``*``, with q above 0)."""
    for coding in accept_encoding.split(","):
        name, _, params = coding.strip().partition(";")
        if name.strip().lower() not in ("gzip", "x-gzip", "*"):
            continue
        q = params.strip().lower().removeprefix("q=")
        try:
            return not params.strip() or float(q) > 0
        except ValueError:
            return True
    return False
