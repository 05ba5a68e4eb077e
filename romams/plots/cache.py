"""Rendered plots cached by the content hash of the data they draw (+ the plot options), in a bounded LRU.

``plot_key`` hashes any tree of dataclasses, arrays, mappings, sequences and scalars (arrays by dtype, shape
and bytes), so two requests that would draw the same figure share one key whatever row or URL they came from;
``PLOT_VERSION`` is part of every key, so a change of the figures' code invalidates what an old process cached.
``PlotCache`` keeps rendered bytes in memory up to ``max_bytes`` (least recently used evicted first); the key
doubles as the HTTP ETag of the image (api/plot_cache.py).
"""

from __future__ import annotations

import dataclasses
import hashlib
import threading
from collections import OrderedDict
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

PLOT_VERSION = "plots-2"  # bump when a figure's drawing code changes what the same data looks like
DEFAULT_MAX_BYTES = 64 * 1024 * 1024


def _feed(h: Any, obj: Any) -> None:
    """Feed one object of a data tree into the hash ``h`` (type-tagged, so different trees never collide)."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        h.update(f"D{type(obj).__qualname__}:".encode())
        for f in dataclasses.fields(obj):
            h.update(f.name.encode() + b"=")
            _feed(h, getattr(obj, f.name))
    elif isinstance(obj, np.ndarray | np.generic):
        a = np.ascontiguousarray(obj)
        if a.dtype.kind == "O":
            _feed(h, a.tolist())
            return
        h.update(f"A{a.dtype.str}{a.shape}:".encode())
        h.update(a.tobytes())
    elif isinstance(obj, Mapping):
        h.update(b"M")
        for k in sorted(obj, key=str):
            h.update(repr(k).encode() + b"=")
            _feed(h, obj[k])
    elif isinstance(obj, list | tuple):
        h.update(f"L{len(obj)}:".encode())
        for v in obj:
            _feed(h, v)
    else:
        h.update(f"S{type(obj).__name__}:{obj!r};".encode())


def plot_key(*parts: Any) -> str:
    """SHA-256 hex digest of the plot version and ``parts`` (the data drawn and the plot options)."""
    h = hashlib.sha256(PLOT_VERSION.encode())
    for p in parts:
        _feed(h, p)
    return h.hexdigest()


class PlotCache:
    """Thread-safe LRU of rendered plots (key -> bytes), bounded by their total size in bytes."""

    def __init__(self, max_bytes: int = DEFAULT_MAX_BYTES) -> None:
        self.max_bytes = int(max_bytes)
        self._items: OrderedDict[str, bytes] = OrderedDict()
        self._size = 0
        self._lock = threading.Lock()
        self.hits = self.misses = 0

    def __len__(self) -> int:
        return len(self._items)

    @property
    def size_bytes(self) -> int:
        """Total size of the cached plots (bytes)."""
        return self._size

    def get(self, key: str) -> bytes | None:
        """The cached bytes of ``key`` (marked most recently used), or None."""
        with self._lock:
            data = self._items.get(key)
            if data is None:
                self.misses += 1
                return None
            self._items.move_to_end(key)
            self.hits += 1
            return data

    def put(self, key: str, data: bytes) -> None:
        """Store ``data`` under ``key``, evicting the least recently used plots beyond ``max_bytes``."""
        if len(data) > self.max_bytes:
            return
        with self._lock:
            old = self._items.pop(key, None)
            self._size -= 0 if old is None else len(old)
            self._items[key] = data
            self._size += len(data)
            while self._size > self.max_bytes:
                _, dropped = self._items.popitem(last=False)
                self._size -= len(dropped)

    def render(self, key: str, draw: Callable[[], bytes]) -> bytes:
        """The cached bytes of ``key``, or ``draw()`` rendered now and cached."""
        data = self.get(key)
        if data is None:
            data = draw()
            self.put(key, data)
        return data
