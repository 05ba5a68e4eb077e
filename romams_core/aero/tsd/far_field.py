"""The steady far field of a 3-D TSD grid: the potential of the wing's circulation (a lifting line and its wake).

In steady flow the non-reflecting conditions reduce to zero normal gradients, i.e. slip walls, whose images add
lift as a closed wind tunnel's walls do (docs/transonic.md 7.3: modes 1-2 of AGARD 445.6 about 2-3 % high from
this alone). The 2-D grid prescribes the compressible vortex of its circulation on its outer faces; this is the
3-D analogue. Each strip j of the span carries its trailing-edge jump Gamma_j as a doublet sheet (normal z) from
the quarter-chord line x_q(y) = x_le + c / 4 to x = +inf; in Prandtl-Glauert coordinates (x / beta, y, z) its
potential solves Laplace's equation, so the physical one solves beta^2 phi_xx + phi_yy + phi_zz = 0:

    phi = 1/(4 pi) * sum_j Gamma_j * int_{strip j} z / rho^2 * (1 + X / R) dy',
    X = (x - x_q(y')) / beta,  rho^2 = (y - y')^2 + z^2,  R^2 = X^2 + rho^2,

which jumps by Gamma_j across z = 0 behind x_q. The gradients, from the integrand's derivatives, are

    phi_x: z / (beta R^3),   phi_y: -z (y - y') (2 (1 + X / R) / rho^4 + X / (rho^2 R^3)),
    phi_z: (1 + X / R) (1 / rho^2 - 2 z^2 / rho^4) - X z^2 / (rho^2 R^3),

integrated over each strip by Gauss-Legendre. A symmetric root adds the mirror strips (an antisymmetric one
with the opposite sign). The outer faces then see phi_n = (this gradient) + (the non-reflecting term), as the
2-D grid's do. Lengths in root chords, the potential in U c_ref.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from romams_core.aero.tsd.grid import TsdGrid

#: Gauss-Legendre points per strip (the outer faces are at least a few strip widths away)
GAUSS_POINTS = 4
#: points per chunk of the [P, S, G] evaluation (memory)
CHUNK = 4096


def strips_of(grid: TsdGrid) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(ya, yb, sign, column) of every strip (c_ref units): the span's node columns and, for a (anti)symmetric
    root, their mirror images; ``column`` is the plane j whose jump the strip carries."""
    cols = np.flatnonzero(grid.strips)
    ya = np.clip(grid.yf[cols], 0.0, grid.semispan)
    yb = np.clip(grid.yf[cols + 1], 0.0, grid.semispan)
    sign = np.ones(cols.size)
    if grid.root == "open":
        return ya, yb, sign, cols
    mirror = 1.0 if grid.root == "symmetric" else -1.0
    return (np.concatenate((ya, -yb)), np.concatenate((yb, -ya)), np.concatenate((sign, mirror * sign)),
            np.concatenate((cols, cols)))


def _quadrature(grid: TsdGrid) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Gauss points of the strips: y' and x_q(y') [S, G] (c_ref units), weights [S, G] (with the strip's sign and
    1 / (4 pi)) and each strip's plane."""
    ya, yb, sign, cols = strips_of(grid)
    nodes, weights = np.polynomial.legendre.leggauss(GAUSS_POINTS)
    half = 0.5 * (yb - ya)
    yq = (0.5 * (yb + ya))[:, None] + half[:, None] * nodes[None, :]
    wq = (sign * half)[:, None] * weights[None, :] / (4.0 * math.pi)
    ay = np.abs(yq)  # a mirror strip's line is the image of its strip's
    return yq, grid.x_le(ay) + 0.25 * grid.chord(ay), wq, cols


def sheet_gradient(grid: TsdGrid, points: np.ndarray, axis: int, beta: float) -> np.ndarray:
    """[P, nj] gradient component ``axis`` (0 x, 1 y, 2 z; 1/c_ref) at ``points`` [P, 3] (c_ref units) of the
    potential of a unit jump on each plane's strip (the columns of planes off the span are zero)."""
    yq, xq, wq, cols = _quadrature(grid)
    out = np.zeros((points.shape[0], grid.shape[1]))
    for lo in range(0, points.shape[0], CHUNK):
        p = points[lo:lo + CHUNK, :, None, None]
        x, y, z = p[:, 0], p[:, 1], p[:, 2]
        X = (x - xq) / beta
        dy = y - yq
        rho2 = dy * dy + z * z
        R = np.sqrt(X * X + rho2)
        R3 = R ** 3
        q = 1.0 + X / R
        if axis == 0:
            d = z / (beta * R3)
        elif axis == 1:
            d = -z * dy * (2.0 * q / (rho2 * rho2) + X / (rho2 * R3))
        else:
            d = q * (1.0 / rho2 - 2.0 * z * z / (rho2 * rho2)) - X * z * z / (rho2 * R3)
        per_strip = np.sum(d * wq, axis=2)  # [P, S]
        np.add.at(out[lo:lo + CHUNK].T, cols, per_strip.T)
    return out


def sheet_potential(grid: TsdGrid, points: np.ndarray, beta: float) -> np.ndarray:
    """[P, nj] potential (U c_ref per unit jump) at ``points`` [P, 3] of each plane's strip (the tests check
    the gradients against it)."""
    yq, xq, wq, cols = _quadrature(grid)
    p = points[:, :, None, None]
    X = (p[:, 0] - xq) / beta
    rho2 = (p[:, 1] - yq) ** 2 + p[:, 2] ** 2
    per_strip = np.sum(p[:, 2] / rho2 * (1.0 + X / np.sqrt(X * X + rho2)) * wq, axis=2)
    out = np.zeros((points.shape[0], grid.shape[1]))
    np.add.at(out.T, cols, per_strip.T)
    return out


def _face_points(grid: TsdGrid) -> dict[str, np.ndarray]:
    """The outer faces' evaluation points [2, ..., 3] (c_ref units): 'u' upstream / downstream (j, k), 'w' bottom /
    top (i, j), 'v' below the root (a free wing's) / lateral (i, k)."""
    ni, nj, nk = grid.shape
    xle, c = grid.x_le(grid.yc), grid.chord(grid.yc)
    u = np.empty((2, nj, nk, 3))
    for side, xi in enumerate((grid.xf[0], grid.xf[-1])):
        u[side, ..., 0] = (xle + c * xi)[:, None]
        u[side, ..., 1] = grid.yc[:, None]
        u[side, ..., 2] = grid.zc[None, :]
    w = np.empty((2, ni, nj, 3))
    x_nodes, y_nodes = grid.node_xy()
    for side, z in enumerate((grid.zf[0], grid.zf[-1])):
        w[side, ..., 0], w[side, ..., 1], w[side, ..., 2] = x_nodes, y_nodes, z
    v = np.empty((2, ni, nk, 3))
    for side, y in enumerate((grid.yf[0], grid.yf[-1])):
        v[side, ..., 0] = (grid.x_le(np.array(y)) + grid.chord(np.array(y)) * grid.xc)[:, None]
        v[side, ..., 1] = y
        v[side, ..., 2] = grid.zc[None, :]
    return {"u": u, "w": w, "v": v}


#: singular values kept in the compressed gradient matrices, relative to the largest (the faces see a smooth field)
RANK_TOL = 1e-9


def _compressed(k: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(A [P, r], B [r, n]) with A B = k to RANK_TOL of its largest singular value (truncated SVD)."""
    u, sv, vt = np.linalg.svd(k, full_matrices=False)
    r = max(1, int(np.sum(sv > RANK_TOL * sv[0]))) if sv.size and sv[0] > 0.0 else 1
    return np.ascontiguousarray(u[:, :r] * sv[:r]), np.ascontiguousarray(vt[:r])


@dataclass
class WakeFarField:
    """The outer faces' far-field gradients per unit jump of each plane on the span, as truncated SVD factors
    (ranks 6-17 of 18-36 planes: 3.5x less to read every sub-iteration, and no BLAS call that could start threads
    beside the record threads); far_u, far_w and far_v of the residual are these times the current jumps."""

    planes: np.ndarray  # [n] the planes on the span (the only ones with a jump)
    factors: dict[str, tuple[np.ndarray, np.ndarray]]  # u: phi_x up/downstream, w: phi_z bottom/top, v: phi_y lateral

    @classmethod
    def of(cls, grid: TsdGrid, beta: float) -> WakeFarField:
        """The factors of a 3-D grid (``lateral_far``) at the Prandtl-Glauert factor ``beta``."""
        pts = _face_points(grid)
        planes = np.flatnonzero(grid.strips)
        full = {name: sheet_gradient(grid, pts[name].reshape(-1, 3), axis, beta)[:, planes]
                for name, axis in (("u", 0), ("w", 2), ("v", 1))}
        if grid.root != "open":  # the root face is a (anti)symmetry plane, not a far field
            full["v"][: full["v"].shape[0] // 2] = 0.0
        return cls(planes=planes, factors={name: _compressed(k) for name, k in full.items()})

    def update(self, jumps: np.ndarray, far_u: np.ndarray, far_w: np.ndarray, far_v: np.ndarray) -> None:
        """Fill the residual's far-field gradients (U) in place from the planes' jumps [nj] (U c_ref)."""
        g = jumps[self.planes]
        for name, out in (("u", far_u), ("w", far_w), ("v", far_v)):
            a, b = self.factors[name]
            np.einsum("pr,r->p", a, b @ g, out=out.reshape(-1))  # (the arrays are C-contiguous: reshape is a view)
