"""Sheared, stretched Cartesian grids for the TSD solver (lengths in units of the root chord c_ref).

The mapping xi = (x - x_le(y)) / c(y), eta = y, zeta = z fits the grid to a trapezoidal planform: the wing is
0 <= xi <= 1, 0 <= y <= b; beyond the tip x_le and c are frozen at their tip values (below the root of a free
wing at their root values). Nodes are cell centres: the leading and trailing edges, the root, the tip and the
mean plane z = 0 are cell faces, so the planform is exactly a union of cells and the slit condition sits on faces
(tsd-notes, section 4). The root face is a symmetry plane (phi mirrored, zero flux), an antisymmetry plane (phi
mirrored with the opposite sign: phi = 0 on it), or, for a free wing (``root`` "open"), an interior face: the
grid then continues to y < 0 with a lateral far field of its own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy.optimize import brentq

from romams_core.errors import InputError


@dataclass(frozen=True)
class GridSpec:
    """Cell counts and extents of a TSD grid (extents in local chords for x, root chords otherwise)."""

    n_chord: int = 40  # cells on the chord, cosine-clustered at LE and TE
    cluster: float = 0.3  # weight of the cosine clustering (0 uniform); fine TE cells cut the stable time step
    n_upstream: int = 14
    n_downstream: int = 22
    x_upstream: float = 8.0  # local chords ahead of the LE
    x_downstream: float = 10.0  # local chords behind the TE
    n_span: int = 18  # cells on the semispan, clustered toward the tip (a free wing's toward both edges)
    span_cluster: float = 0.5  # weight of the sine clustering of the span's cells (0 uniform; 0.5: tip 2.6x finer)
    n_outboard: int = 10  # cells beyond the tip (and, for a free wing, as many below the root)
    y_outboard: float = 5.0  # far lateral boundary, in semispans from the root (y_outboard - 1 beyond each edge)
    n_z: int = 22  # cells on each side of the mean plane
    dz0: float = 0.02  # first cell height at the mean plane
    z_max: float = 8.0

    def __post_init__(self) -> None:
        for name, lo in (("n_chord", 8), ("n_upstream", 3), ("n_downstream", 3), ("n_span", 2),
                         ("n_outboard", 2), ("n_z", 4)):
            v = getattr(self, name)
            if not (isinstance(v, int | np.integer) and lo <= v <= 2000):
                raise InputError(f"grid.{name}", f"must be an integer in [{lo}, 2000], got {v!r}")
        for name in ("x_upstream", "x_downstream", "y_outboard", "dz0", "z_max"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise InputError(f"grid.{name}", f"must be a finite number > 0, got {v!r}")
        if self.y_outboard <= 1.0:
            raise InputError("grid.y_outboard", f"must be > 1 semispan, got {self.y_outboard}")
        for name in ("cluster", "span_cluster"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and 0.0 <= v <= 1.0):
                raise InputError(f"grid.{name}", f"must be in [0, 1], got {v!r}")
        if self.dz0 * self.n_z >= self.z_max:
            raise InputError("grid.dz0", f"dz0 * n_z = {self.dz0 * self.n_z:g} must be below z_max = {self.z_max:g}")

    def scaled(self, factor: float, axes: str = "xyz") -> GridSpec:
        """The same grid with the cell counts along ``axes`` (any of x, y, z; default all) multiplied by ``factor``
        (z: the first height divided by it)."""
        def n(v: int) -> int:
            return max(2, int(round(v * factor)))
        new: dict[str, Any] = {name: n(getattr(self, name)) for axis in axes for name in AXIS_COUNTS[axis]}
        if "z" in axes:
            new["dz0"] = self.dz0 / factor
        return replace(self, **new)


#: the cell counts of a GridSpec along each axis (``GridSpec.scaled``)
AXIS_COUNTS = {"x": ("n_chord", "n_upstream", "n_downstream"), "y": ("n_span", "n_outboard"), "z": ("n_z",)}


#: the grid's root condition for each wing symmetry (romams_core.wing.SYMMETRIES)
ROOT_OF_SYMMETRY = {"symmetric": "symmetric", "antisymmetric": "antisymmetric", "none": "open"}
#: the kernels' code of each root condition
ROOT_CODES = {"symmetric": 0, "antisymmetric": 1, "open": 2}


@dataclass
class TsdGrid:
    """A sheared TSD grid: faces and centres per direction, metrics, planform and wake masks."""

    xf: np.ndarray  # [ni+1] xi faces
    yf: np.ndarray  # [nj+1] y faces (c_ref units)
    zf: np.ndarray  # [nk+1] z faces, zf[k0+1] == 0
    semispan: float  # b / c_ref; inf for a 2-D (span-invariant) grid
    tan_sweep: float
    taper: float  # tip chord / root chord
    lateral_far: bool  # False: the outer y face is a symmetry plane too (2-D)
    kinks: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))  # [K, 3] (y, x_le, chord), c_ref units
    root: str = "symmetric"  # root face y = 0: "symmetric", "antisymmetric" or "open" (a free wing, y < 0 gridded)
    xc: np.ndarray = field(init=False)
    yc: np.ndarray = field(init=False)
    zc: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        if self.root not in ROOT_CODES:
            raise InputError("root", f"must be one of {tuple(ROOT_CODES)}, got {self.root!r}")
        self.xc = 0.5 * (self.xf[1:] + self.xf[:-1])
        self.yc = 0.5 * (self.yf[1:] + self.yf[:-1])
        self.zc = 0.5 * (self.zf[1:] + self.zf[:-1])

    @property
    def shape(self) -> tuple[int, int, int]:
        """Nodes (ni, nj, nk)."""
        return (self.xc.size, self.yc.size, self.zc.size)

    @property
    def n_points(self) -> int:
        """Number of grid nodes."""
        ni, nj, nk = self.shape
        return ni * nj * nk

    @property
    def k0(self) -> int:
        """Index of the last node below the mean plane."""
        return int(np.searchsorted(self.zf, 0.0)) - 1

    @property
    def root_code(self) -> int:
        """The kernels' code of the root condition (ROOT_CODES)."""
        return ROOT_CODES[self.root]

    @property
    def strips(self) -> np.ndarray:
        """[nj] True for the node columns on the span, 0 < y < semispan."""
        return (self.yc > 0.0) & (self.yc < self.semispan)

    @property
    def stations(self) -> np.ndarray:
        """[S, 3] planform stations (y, x_le, chord; c_ref units) from root to tip, the kinks between."""
        tip = (self.semispan, self.semispan * self.tan_sweep, self.taper)
        return np.vstack([[0.0, 0.0, 1.0], np.reshape(self.kinks, (-1, 3)), [tip]])

    def chord(self, y: np.ndarray) -> np.ndarray:
        """Local chord (c_ref units) of the mapping at y (frozen beyond the tip and below the root)."""
        if len(self.kinks) == 0:
            eta = np.clip(np.asarray(y, dtype=float) / self.semispan, 0.0, 1.0)
            return 1.0 + (self.taper - 1.0) * eta
        st = self.stations
        return np.interp(np.asarray(y, dtype=float), st[:, 0], st[:, 2])

    def x_le(self, y: np.ndarray) -> np.ndarray:
        """Leading-edge x (c_ref units) of the mapping at y (frozen beyond the tip and below the root)."""
        if len(self.kinks) == 0:
            return np.clip(np.asarray(y, dtype=float), 0.0, self.semispan) * self.tan_sweep
        st = self.stations
        return np.interp(np.asarray(y, dtype=float), st[:, 0], st[:, 1])

    def _slopes(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(x_le', c') at y inside the span, the mean of both sides at a kink (c_ref units per c_ref)."""
        st = self.stations
        dxle, dc = np.diff(st[:, 1]) / np.diff(st[:, 0]), np.diff(st[:, 2]) / np.diff(st[:, 0])
        right = np.clip(np.searchsorted(st[:, 0], y, side="right") - 1, 0, dc.size - 1)
        left = np.clip(np.searchsorted(st[:, 0], y, side="left") - 1, 0, dc.size - 1)
        return 0.5 * (dxle[left] + dxle[right]), 0.5 * (dc[left] + dc[right])

    def xi_y(self, xi: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Metric d(xi)/dy = -(x_le' + xi c') / c at (xi, y) (1/c_ref); zero beyond the tip and below the root,
        averaged over both sides at the tip, the kinks and the root."""
        xi, y = np.broadcast_arrays(np.asarray(xi, float), np.asarray(y, float))
        c = self.chord(y)
        dxle, dc = self._slopes(y)
        inboard = -(dxle + xi * dc) / c
        val = np.where((y < self.semispan) & (y >= 0.0), inboard, 0.0)
        edge = np.isclose(y, self.semispan) | np.isclose(y, 0.0, rtol=0.0, atol=1e-12)
        return np.where(edge, 0.5 * inboard, val)

    @property
    def wing(self) -> np.ndarray:
        """[ni, nj] True for nodes on the planform."""
        return ((self.xc > 0.0) & (self.xc < 1.0))[:, None] & self.strips[None, :]

    @property
    def wake(self) -> np.ndarray:
        """[ni, nj] True for nodes of the wake sheet (behind the trailing edge, on the span)."""
        return (self.xc > 1.0)[:, None] & self.strips[None, :]

    def node_xy(self) -> tuple[np.ndarray, np.ndarray]:
        """Physical x and y (c_ref units) of the (i, j) node columns, each [ni, nj]."""
        y = np.broadcast_to(self.yc[None, :], self.shape[:2])
        x = self.x_le(self.yc)[None, :] + self.xc[:, None] * self.chord(self.yc)[None, :]
        return x, np.array(y)

    def cell_areas(self) -> np.ndarray:
        """[ni, nj] planform area of each node column's cell (c_ref^2 units; per unit span in 2-D)."""
        return (np.diff(self.xf)[:, None] * self.chord(self.yc)[None, :]) * np.diff(self.yf)[None, :]


def geometric_faces(h0: float, length: float, n: int) -> np.ndarray:
    """n+1 face offsets from 0 to ``length`` whose first cell is h0, growing geometrically (uniform if needed)."""
    if n * h0 >= length:
        return np.linspace(0.0, length, n + 1)
    def total(r: float) -> float:
        return h0 * (r ** n - 1.0) / (r - 1.0) - length
    hi = 2.0
    while total(hi) < 0.0:
        hi *= 2.0
    r = brentq(total, 1.0 + 1e-9, hi)
    return np.concatenate(([0.0], np.cumsum(h0 * r ** np.arange(n))))


def chord_faces(n: int, weight: float = 0.75) -> np.ndarray:
    """n+1 faces on [0, 1], a blend of cosine (clustered at both ends) and uniform spacing."""
    s = np.linspace(0.0, 1.0, n + 1)
    return weight * 0.5 * (1.0 - np.cos(np.pi * s)) + (1.0 - weight) * s


def _xi_faces(spec: GridSpec) -> np.ndarray:
    """Streamwise faces in local chords: upstream stretch, clustered chord, downstream stretch."""
    wing = chord_faces(spec.n_chord, spec.cluster)
    h_le, h_te = wing[1] - wing[0], wing[-1] - wing[-2]
    up = geometric_faces(h_le, spec.x_upstream, spec.n_upstream)
    down = geometric_faces(h_te, spec.x_downstream, spec.n_downstream)
    return np.concatenate((-up[::-1], wing[1:], 1.0 + down[1:]))


def _z_faces(spec: GridSpec) -> np.ndarray:
    """Normal faces, symmetric about the mean plane z = 0."""
    half = geometric_faces(spec.dz0, spec.z_max, spec.n_z)
    return np.concatenate((-half[::-1], half[1:]))


def _span_faces(length: float, n: int, weight: float = 0.5) -> np.ndarray:
    """n+1 faces on [0, length] (c_ref units) clustered toward ``length`` by a sine of ``weight`` (0 uniform; 0.5:
    a tip's cells 2.6x finer than at 0)."""
    s = np.linspace(0.0, 1.0, n + 1)
    return length * (weight * np.sin(0.5 * np.pi * s) + (1.0 - weight) * s)


def wing_grid(semispan: float, taper: float, tan_sweep: float, spec: GridSpec | None = None,
              kinks: np.ndarray | None = None, root: str = "symmetric") -> TsdGrid:
    """Sheared grid for a trapezoidal half wing (semispan and chords in root chords) whose root face is a
    symmetry or antisymmetry plane (``root``), or for a free wing (``root`` "open"): then the span's faces are
    clustered toward both edges (half the cells on each half span, each half like a half wing's) and the
    outboard faces are mirrored below the root, so the grid is symmetric about mid-span; ``kinks`` [K, 3]
    (y, x_le, chord in root chords) make it a cranked one."""
    spec = spec or GridSpec()
    if not (math.isfinite(semispan) and semispan > 0):
        raise InputError("planform.semispan", f"must be > 0, got {semispan!r}")
    if root == "open":  # (an unknown root is refused by TsdGrid)
        half, n_lo = 0.5 * semispan, spec.n_span // 2
        upper = half + _span_faces(half, spec.n_span - n_lo, spec.span_cluster)
        lower = half - _span_faces(half, n_lo, spec.span_cluster)[::-1]
        wing_y = np.concatenate((lower, upper[1:]))
        below = geometric_faces(wing_y[1] - wing_y[0], (spec.y_outboard - 1.0) * semispan, spec.n_outboard)
        inner = np.concatenate((-below[:0:-1], wing_y))  # the root edge is a tip too
    else:
        wing_y = inner = _span_faces(semispan, spec.n_span, spec.span_cluster)
    h_tip = wing_y[-1] - wing_y[-2]
    out = geometric_faces(h_tip, (spec.y_outboard - 1.0) * semispan, spec.n_outboard)
    yf = np.concatenate((inner, semispan + out[1:]))
    return TsdGrid(xf=_xi_faces(spec), yf=yf, zf=_z_faces(spec), semispan=float(semispan),
                   tan_sweep=float(tan_sweep), taper=float(taper), lateral_far=True,
                   kinks=np.zeros((0, 3)) if kinks is None else np.reshape(np.asarray(kinks, float), (-1, 3)),
                   root=root)


def airfoil_grid(spec: GridSpec | None = None) -> TsdGrid:
    """Span-invariant (2-D) grid: one unit-width cell in y between two symmetry planes."""
    spec = spec or GridSpec(n_chord=50, cluster=0.0, n_upstream=24, n_downstream=24, x_upstream=20.0,
                            x_downstream=20.0, n_z=34, dz0=0.02, z_max=20.0)
    return TsdGrid(xf=_xi_faces(spec), yf=np.array([0.0, 1.0]), zf=_z_faces(spec), semispan=math.inf,
                   tan_sweep=0.0, taper=1.0, lateral_far=False)
