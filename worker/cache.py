"""Bounded in-memory caches of a worker process: loaded wings, bases and ROMs, and flutter results."""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Callable, Hashable
from typing import Any


class LruCache:
    """Thread-safe least-recently-used mapping holding at most ``maxsize`` entries."""

    def __init__(self, maxsize: int) -> None:
        self.maxsize = int(maxsize)
        self._data: OrderedDict[Hashable, Any] = OrderedDict()
        self._lock = threading.Lock()
        self.hits = 0
        self.misses = 0

    def get(self, key: Hashable, default: Any = None) -> Any:
        """Cached value or ``default`` (counts a hit or miss)."""
        with self._lock:
            if key in self._data:
                self._data.move_to_end(key)
                self.hits += 1
                return self._data[key]
            self.misses += 1
            return default

    def put(self, key: Hashable, value: Any) -> None:
        """Insert, evicting the least recently used entries beyond ``maxsize``."""
        if self.maxsize <= 0:
            return
        with self._lock:
            self._data[key] = value
            self._data.move_to_end(key)
            while len(self._data) > self.maxsize:
                self._data.popitem(last=False)

    def get_or_load(self, key: Hashable, load: Callable[[], Any]) -> Any:
        """Cached value, or ``load()`` stored under ``key``."""
        sentinel = object()
        value = self.get(key, sentinel)
        if value is sentinel:
            value = load()
            self.put(key, value)
        return value

    def __len__(self) -> int:
        return len(self._data)
