"""A thread-safe LRU (cachetools') for values derived from rows that never change.

A publication is frozen once written and an artifact is named by its content, so what
is read from them can be kept for the life of the process: trace validation then costs
no edge scan per upload, and the publication JSON is rendered once.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Hashable
from typing import Generic, TypeVar

from cachetools import LRUCache

V = TypeVar("V")


class FrozenCache(Generic[V]):
    def __init__(self, maxsize: int) -> None:
        self._items: LRUCache[Hashable, V] = LRUCache(maxsize)
        self._lock = threading.Lock()

    def get_or_load(self, key: Hashable, load: Callable[[], V]) -> V:
        """The cached value, or ``load()`` stored; a failing load caches nothing."""
        with self._lock:
            if key in self._items:
                return self._items[key]  # a read marks the entry as recently used
        value = load()  # outside the lock: loads may be slow; a duplicate load is harmless
        with self._lock:
            self._items[key] = value
        return value
