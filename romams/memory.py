"""Keeping a long-running process's resident memory bounded: glibc's malloc arenas and heap trimming.

Under many concurrent requests, the API's thread pool makes glibc create one malloc arena per thread (up to 8
per core), and memory freed after the burst stays mapped inside those arenas. ``limit_malloc_arenas`` caps the
number of arenas (``mallopt(M_ARENA_MAX)``, effective for arenas created afterwards) and ``trim_heap`` hands the
free pages of every arena back to the kernel (``malloc_trim(0)``). Both are no-ops without glibc.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
from typing import Any

from romams.periodic import Periodic

M_ARENA_MAX = -8  # mallopt parameter number of glibc's malloc.h


@functools.cache
def _glibc() -> Any:
    """The C library if it is glibc (it has malloc_trim and mallopt), else None."""
    name = ctypes.util.find_library("c")
    if not name:
        return None
    try:
        libc = ctypes.CDLL(name)
    except OSError:
        return None
    if not (hasattr(libc, "malloc_trim") and hasattr(libc, "mallopt")):
        return None
    return libc


def limit_malloc_arenas(n: int) -> bool:
    """Cap glibc's malloc arenas at ``n`` (arenas created from now on); False where not applied (n <= 0, no glibc)."""
    libc = _glibc()
    if n <= 0 or libc is None:
        return False
    return bool(libc.mallopt(ctypes.c_int(M_ARENA_MAX), ctypes.c_int(n)))


def trim_heap() -> bool:
    """Return the free pages of every malloc arena to the kernel; True if some memory was released."""
    libc = _glibc()
    return bool(libc is not None and libc.malloc_trim(ctypes.c_size_t(0)))


def heap_trimmer(period_s: float) -> Periodic:
    """A (not yet started) daemon thread calling :func:`trim_heap` every ``period_s`` seconds."""

    def trim() -> None:  # whether pages were released does not matter: the thread keeps going
        trim_heap()

    return Periodic(trim, period_s, "romams-heap-trim")
