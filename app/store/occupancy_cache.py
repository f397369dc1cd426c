"""Occupancy grids cached in Redis: the paper's memcached of hot clip data (section 6).

Every best-target search compares a new clip with up to K stored ones, and the popular
targets are the same on every worker; each worker's own LRU cache warms up alone, so
this shared layer sits between it and the artifact files. Keys are bundle digests
(content hashes), so an entry is never stale: it only expires (``ttl``) or is evicted.
Redis being down costs speed, never correctness: a failed read or write is a miss.
"""

from __future__ import annotations

import logging
from typing import Any

import numpy as np

from app.store.array_codec import CorruptArrays, decode_arrays, encode_arrays

KEY_PREFIX = "srg:occupancy:"
log = logging.getLogger(__name__)


class RedisShapeCache:
    """(occupancy, descriptor) of clip bundles in Redis, in the artifacts' arrays format."""

    def __init__(self, client: Any, ttl: int) -> None:
        self._client = client
        self._ttl = ttl
        self.hits = 0
        self.misses = 0

    @classmethod
    def from_url(cls, url: str, ttl: int) -> RedisShapeCache:
        import redis

        return cls(redis.Redis.from_url(url, socket_timeout=2.0), ttl)

    def get(self, digest: str) -> tuple[np.ndarray, np.ndarray] | None:
        try:
            data = self._client.get(KEY_PREFIX + digest)
        except Exception as exc:  # any Redis failure is a miss (see the module docstring)
            log.warning("occupancy cache read failed: %s", exc)
            data = None
        try:
            arrays = None if data is None else decode_arrays(data)
        except CorruptArrays:  # an entry of an older format: a miss, rewritten on put
            arrays = None
        if arrays is None:
            self.misses += 1
            return None
        self.hits += 1
        return arrays["occupancy"], arrays["descriptor"]

    def put(self, digest: str, occupancy: np.ndarray, descriptor: np.ndarray) -> None:
        data = encode_arrays({"occupancy": occupancy, "descriptor": descriptor})
        try:
            self._client.set(KEY_PREFIX + digest, data, ex=self._ttl)
        except Exception as exc:
            log.warning("occupancy cache write failed: %s", exc)
