"""The Redis occupancy cache speaks the artifacts' arrays format; older entries are misses."""

from __future__ import annotations

import numpy as np

from app.store.occupancy_cache import KEY_PREFIX, RedisShapeCache


class DictRedis:
    def __init__(self) -> None:
        self.data: dict[str, bytes] = {}

    def get(self, key: str) -> bytes | None:
        return self.data.get(key)

    def set(self, key: str, value: bytes, ex: int) -> None:
        self.data[key] = value


def test_entries_round_trip_and_an_npz_entry_is_a_miss() -> None:
    client = DictRedis()
    cache = RedisShapeCache(client, ttl=60)
    occupancy = np.arange(600, dtype=np.uint8).reshape(2, 300)
    cache.put("a", occupancy, np.linspace(0, 1, 72))
    hit = cache.get("a")
    assert hit is not None and np.array_equal(hit[0], occupancy)
    client.data[KEY_PREFIX + "b"] = b"PK\x03\x04 an npz of the format before"
    assert cache.get("b") is None
    assert (cache.hits, cache.misses) == (1, 1)
