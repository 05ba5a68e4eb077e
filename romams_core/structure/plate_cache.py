"""The sparse pattern of a plate wing's FE model, found once per mesh topology and reused by every design.

The designs of one wing move the FE nodes (the mesh follows the beam line) and change every element matrix,
but not the connectivity: the same triangles, beam elements, DOF layout and clamped root. So the summed CSC
pattern of K and M, the place of each element entry in it and the free-free block's band layout are kept here
(``sparse_pattern``), keyed by the connectivity itself; a design's matrices are then summed into it with one
``np.bincount`` each. At most ``CACHE_SIZE`` topologies are kept, least recently used dropped.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from romams_core.structure.sparse_pattern import FreePart, Pattern

CACHE_SIZE = 16


@dataclass(frozen=True)
class Topology:
    """Pattern of a set of element groups, each group's entry positions in it, and its free-free layout."""

    pattern: Pattern
    positions: tuple[np.ndarray, ...]  # per group (``conns`` order) [E n n]
    free_part: FreePart


_CACHE: OrderedDict[tuple[object, ...], Topology] = OrderedDict()
_LOCK = threading.Lock()


def topology(conns: list[np.ndarray], n_dof: int, free: np.ndarray) -> Topology:
    """The cached Topology of element groups with connectivities ``conns`` on n_dof DOFs, ``free`` kept."""
    key = (n_dof, free.tobytes(), *((c.shape, c.tobytes()) for c in conns))
    with _LOCK:
        top = _CACHE.get(key)
        if top is not None:
            _CACHE.move_to_end(key)
            return top
    pattern = Pattern.of(conns, n_dof)
    pos = tuple(pattern.positions(c) for c in conns)
    assert all(p is not None for p in pos)
    top = Topology(pattern, pos, FreePart.of(pattern, free))  # type: ignore[arg-type]
    with _LOCK:
        _CACHE[key] = top
        while len(_CACHE) > CACHE_SIZE:
            _CACHE.popitem(last=False)
    return top


def clear_cache() -> None:
    """Drop every cached topology."""
    with _LOCK:
        _CACHE.clear()
