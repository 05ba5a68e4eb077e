"""Structured triangular FE mesh of a trapezoidal planform in chord / span fractions.

Nodes lie on ``n_span + 1`` equally spaced span stations and ``n_chord + 1`` chordwise lines;
node (i chordwise, j spanwise) has index ``j * (n_chord + 1) + i`` (as on the standard mesh).
With a beam line (root chord fraction ``x1`` of the root chord to ``x2`` of the tip chord, a
straight line in physical space), one chordwise node line runs exactly along it, so its nodes
carry the beam; the chordwise cells ahead of / behind it are spread evenly, and the number of
cells ahead of the line follows the line's mean chord fraction (the mesh changes with design).
Each quadrilateral cell is split into two counter-clockwise triangles along its shorter diagonal.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from romams_core.errors import InputError
from romams_core.mesh import Planform


@dataclass(frozen=True)
class PlateMesh:
    """Nodes (m), triangles, and the structured grid bookkeeping of a plate FE mesh."""

    n_chord: int
    n_span: int
    xy: np.ndarray = field(repr=False)  # [P, 2] node coordinates, m
    xi: np.ndarray = field(repr=False)  # [n_span + 1, n_chord + 1] chord fraction of each node
    triangles: np.ndarray = field(repr=False)  # [2 * n_chord * n_span, 3] node indices, counter-clockwise
    beam_column: int = -1  # chordwise index i of the node line carrying the beam; -1: none

    @property
    def n_nodes(self) -> int:
        """Number of FE nodes."""
        return int(self.xy.shape[0])

    def node(self, i: np.ndarray | int, j: np.ndarray | int) -> np.ndarray:
        """Flat node index of chordwise index i and span index j."""
        return np.asarray(j) * (self.n_chord + 1) + np.asarray(i)

    def beam_nodes(self) -> np.ndarray:
        """Node indices [n_span + 1] along the beam line (root to tip); empty without a beam."""
        if self.beam_column < 0:
            return np.zeros(0, dtype=int)
        return self.node(self.beam_column, np.arange(self.n_span + 1))


def beam_chord_fraction(planform: Planform, x1: float, x2: float, eta: np.ndarray) -> np.ndarray:
    """Chord fraction of the straight beam line (x1 of root chord to x2 of tip chord) at span fractions eta."""
    eta = np.asarray(eta, dtype=float)
    cr, ct = planform.root_chord, planform.tip_chord
    return ((1.0 - eta) * x1 * cr + eta * x2 * ct) / ((1.0 - eta) * cr + eta * ct)


def plate_mesh(
    planform: Planform, n_chord: int, n_span: int, beam_line: tuple[float, float] | None = None
) -> PlateMesh:
    """Structured DKT mesh of the planform with n_chord x n_span cells, optionally along a beam line."""
    if n_chord < 2 or n_span < 1:
        raise InputError("structure.fe_mesh", f"need n_chord >= 2 and n_span >= 1, got {n_chord} x {n_span}")
    eta = np.linspace(0.0, 1.0, n_span + 1)
    if beam_line is None:
        xi = np.broadcast_to(np.linspace(0.0, 1.0, n_chord + 1), (n_span + 1, n_chord + 1)).copy()
        col = -1
    else:
        xb = beam_chord_fraction(planform, beam_line[0], beam_line[1], eta)
        col = int(np.clip(round(n_chord * float(xb.mean())), 1, n_chord - 1))
        fwd = np.linspace(0.0, 1.0, col + 1)[None, :] * xb[:, None]
        aft = xb[:, None] + np.linspace(0.0, 1.0, n_chord - col + 1)[None, 1:] * (1.0 - xb[:, None])
        xi = np.concatenate([fwd, aft], axis=1)
    x, y = planform.to_xy(xi, np.broadcast_to(eta[:, None], xi.shape))
    xy = np.column_stack([x.ravel(), y.ravel()])
    i, j = np.meshgrid(np.arange(n_chord), np.arange(n_span))
    p00 = (j * (n_chord + 1) + i).ravel()
    p10, p01 = p00 + 1, p00 + n_chord + 1
    p11 = p01 + 1
    d1 = np.linalg.norm(xy[p11] - xy[p00], axis=1)
    d2 = np.linalg.norm(xy[p01] - xy[p10], axis=1)
    use_main = (d1 <= d2)[:, None]
    t1 = np.where(use_main, np.column_stack([p00, p10, p11]), np.column_stack([p00, p10, p01]))
    t2 = np.where(use_main, np.column_stack([p00, p11, p01]), np.column_stack([p10, p11, p01]))
    tri = np.empty((2 * p00.size, 3), dtype=int)
    tri[0::2], tri[1::2] = t1, t2  # cell c holds triangles 2c and 2c + 1
    return PlateMesh(n_chord=n_chord, n_span=n_span, xy=xy, xi=xi, triangles=tri, beam_column=col)


def locate(mesh: PlateMesh, x: np.ndarray, y: np.ndarray, semispan: float) -> tuple[np.ndarray, np.ndarray]:
    """Triangle index [P] and area coordinates [P, 3] of points (m) inside the planform."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    nc, ns = mesh.n_chord, mesh.n_span
    eta = np.clip(y / semispan, 0.0, 1.0)
    jf = np.minimum((eta * ns).astype(int), ns - 1)
    v = eta * ns - jf
    xg = mesh.xy[:, 0].reshape(ns + 1, nc + 1)
    xl = (1.0 - v)[:, None] * xg[jf] + v[:, None] * xg[jf + 1]  # chord lines at each point's y
    i = np.clip(np.sum(xl[:, 1:nc] <= x[:, None], axis=1), 0, nc - 1)
    cell = jf * nc + i
    pts = np.column_stack([x, y])
    best_l = None
    best_t = None
    best_min = None
    for k in (0, 1):
        t = 2 * cell + k
        lam = _barycentric(mesh.xy[mesh.triangles[t]], pts)
        mn = lam.min(axis=1)
        if best_l is None:
            best_l, best_t, best_min = lam, t, mn
        else:
            take = mn > best_min
            best_l = np.where(take[:, None], lam, best_l)
            best_t = np.where(take, t, best_t)
    assert best_l is not None and best_t is not None  # the loop ran
    lam = np.clip(best_l, 0.0, None)
    return best_t, lam / lam.sum(axis=1, keepdims=True)


def _barycentric(tri_xy: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Area coordinates [P, 3] of points [P, 2] in triangles [P, 3, 2]."""
    a, b, c = tri_xy[:, 0], tri_xy[:, 1], tri_xy[:, 2]
    v0, v1, v2 = b - a, c - a, pts - a
    den = v0[:, 0] * v1[:, 1] - v1[:, 0] * v0[:, 1]
    l2 = (v2[:, 0] * v1[:, 1] - v1[:, 0] * v2[:, 1]) / den
    l3 = (v0[:, 0] * v2[:, 1] - v2[:, 0] * v0[:, 1]) / den
    return np.column_stack([1.0 - l2 - l3, l2, l3])
