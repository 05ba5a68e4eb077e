"""Fixed-pattern sparse assembly: the summed pattern of element groups is found once, then each structure's
matrices are summed into it (``np.bincount``) instead of sorting coordinates again.

Used by the plate model (``plate_cache``): every design of one wing has the same mesh, connectivity and clamped
root, so only the element values change between designs (docs/performance.md, "modal analysis").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp


def entry_keys(conn: np.ndarray, n: int) -> np.ndarray:
    """Column-major keys col * n + row [E n n] of the element entries of connectivity conn [E, n] (ravel order of
    element matrices [E, n, n])."""
    m = conn.shape[1]
    rows = np.repeat(conn, m, axis=1).ravel()
    cols = np.tile(conn, (1, m)).ravel()
    return cols.astype(np.int64) * n + rows


def _frozen(*arrays: np.ndarray) -> tuple[np.ndarray, ...]:
    """The arrays made read-only: every matrix on a pattern shares its index arrays, so none may change them."""
    for a in arrays:
        a.flags.writeable = False
    return arrays


@dataclass(frozen=True)
class Pattern:
    """The summed CSC pattern on n DOFs of a set of connectivities (``keys``: its sorted entry keys)."""

    n: int
    keys: np.ndarray  # [nnz] col * n + row, ascending (CSC order)
    indices: np.ndarray  # [nnz] row of each entry
    indptr: np.ndarray  # [n + 1]

    @classmethod
    def of(cls, conns: list[np.ndarray], n: int) -> Pattern:
        """The pattern of element groups with connectivities ``conns`` on n DOFs."""
        keys = np.unique(np.concatenate([entry_keys(c, n) for c in conns]))
        indptr = np.zeros(n + 1, dtype=np.int64)
        np.cumsum(np.bincount(keys // n, minlength=n), out=indptr[1:])
        return cls(n, *_frozen(keys, (keys % n).astype(np.int32), indptr))

    def positions(self, conn: np.ndarray) -> np.ndarray | None:
        """Data positions [E n n] of the element entries of conn; None when some entry is not in the pattern."""
        return self._find(entry_keys(conn, self.n))

    def place(self, conn: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """(positions, values) of the nonzero entries of element matrices ``values`` on conn; None when one of
        them is not in the pattern."""
        v = values.ravel()
        nz = v != 0.0
        pos = self._find(entry_keys(conn, self.n)[nz])
        return None if pos is None else (pos, v[nz])

    def _find(self, k: np.ndarray) -> np.ndarray | None:
        """Data positions of entry keys k; None when one is not in the pattern."""
        pos = np.minimum(np.searchsorted(self.keys, k), self.keys.size - 1)
        return pos if np.array_equal(self.keys[pos], k) else None

    def matrix(self, positions: list[np.ndarray], values: list[np.ndarray]) -> sp.csc_matrix:
        """The CSC matrix summing element matrices ``values`` (any shape, ravelled) at ``positions``."""
        data = np.bincount(np.concatenate(positions), weights=np.concatenate([v.ravel() for v in values]),
                           minlength=self.keys.size)
        return sp.csc_matrix((data, self.indices, self.indptr), shape=(self.n, self.n))


@dataclass(frozen=True)
class FreePart:
    """The free-free block of matrices on a ``Pattern`` (DOFs ``free`` kept, in order) and its upper band layout
    for ``scipy.linalg.cholesky_banded``."""

    free: np.ndarray  # [n_free] kept DOFs (ascending)
    select: np.ndarray  # [nnz_free] data positions of the full pattern that form the block, in its CSC order
    indices: np.ndarray
    indptr: np.ndarray
    upper: np.ndarray  # block data positions with col >= row
    band: int  # upper bandwidth u
    band_flat: np.ndarray  # flat index into the [u + 1, n_free] band array of each ``upper`` entry

    @classmethod
    def of(cls, pattern: Pattern, free: np.ndarray) -> FreePart:
        """The block of ``pattern`` on the DOFs ``free``."""
        new = np.full(pattern.n, -1, dtype=np.int64)
        new[free] = np.arange(free.size)
        r, c = new[pattern.keys % pattern.n], new[pattern.keys // pattern.n]
        select = np.flatnonzero((r >= 0) & (c >= 0))
        r, c = r[select], c[select]
        nf = free.size
        indptr = np.zeros(nf + 1, dtype=np.int64)
        np.cumsum(np.bincount(c, minlength=nf), out=indptr[1:])
        upper = np.flatnonzero(c >= r)
        u = int((c[upper] - r[upper]).max(initial=0))
        flat = (u + r[upper] - c[upper]) * nf + c[upper]
        sel, idx, ptr, up, fl = _frozen(select, r.astype(np.int32), indptr, upper, flat)
        return cls(_frozen(np.array(free))[0], sel, idx, ptr, up, u, fl)

    def block(self, full: sp.csc_matrix) -> sp.csc_matrix:
        """The free-free block of a matrix assembled on the pattern."""
        nf = self.free.size
        return sp.csc_matrix((full.data[self.select], self.indices, self.indptr), shape=(nf, nf))

    def banded_upper(self, block: sp.csc_matrix) -> np.ndarray:
        """The block's upper band [u + 1, n_free] (LAPACK upper storage)."""
        ab = np.zeros((self.band + 1, self.free.size))
        ab.ravel()[self.band_flat] = block.data[self.upper]
        return ab
