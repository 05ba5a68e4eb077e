"""Allman's membrane triangle with drilling rotations, vectorized over elements.

Nodal degrees of freedom (3 per node): in-plane displacements u, v (m) and the drilling
rotation theta_z (rad) about the plate normal, in the global x-y axes.

Allman (1984) derived as in Cook's textbook: the element is the 6-node quadratic (linear-strain)
triangle whose midside displacements are tied to the corner DOFs. On side i -> j (vector
(x_ij, y_ij) = a_j - a_i, length l, left normal n = (-y_ij, x_ij) / l) the normal displacement
is the cubic Hermite curve with end slopes theta_i, theta_j (a rigid rotation theta gives
du_n/ds = theta); its midpoint value gives

    u_m = (u_i + u_j) / 2 + y_ij (theta_j - theta_i) / 8,
    v_m = (v_i + v_j) / 2 + x_ij (theta_i - theta_j) / 8,

while the tangential component stays linear. Strains are linear, so the 3-point side-midpoint
rule integrates the stiffness exactly. The element passes the constant-strain patch test
(a linear field has theta-free midsides) and is conforming with its neighbours (both share the
side's quadratic). One zero-energy mode beyond the three rigid ones remains: equal drilling
rotations at all nodes with u = v = 0 (it moves nothing). In an assembled mesh it is a single
global mode, removed by clamping any drilling DOF (the clamped root does).

Mass: consistent mass of the same quadratic field (it gives the drilling DOFs inertia), so a
unit in-plane translation has exactly the element mass.
"""

from __future__ import annotations

import math
from itertools import product

import numpy as np

from romams_core.structure.dkt import quadratic_gradient_operator, triangle_geometry

_SIDES = ((0, 1), (1, 2), (2, 0))  # midside nodes 4, 5, 6, as in the DKT quadratic triangle


def _quadratic_gram() -> np.ndarray:
    """Integral of N_a N_b over a triangle of unit area [6, 6] for the 6-node quadratic shape functions."""
    polys: list[dict[tuple[int, ...], float]] = []
    for i in range(3):  # corners: 2 L_i^2 - L_i
        sq, lin = [0, 0, 0], [0, 0, 0]
        sq[i], lin[i] = 2, 1
        polys.append({tuple(sq): 2.0, tuple(lin): -1.0})
    for i, j in _SIDES:  # midsides: 4 L_i L_j
        m = [0, 0, 0]
        m[i] += 1
        m[j] += 1
        polys.append({tuple(m): 4.0})

    def integral(p: dict[tuple[int, ...], float], q: dict[tuple[int, ...], float]) -> float:
        """int p q dA / A with int L^g dA = 2 A g! / (|g| + 2)!."""
        total = 0.0
        for (ga, ca), (gb, cb) in product(p.items(), q.items()):
            g = [a + b for a, b in zip(ga, gb, strict=True)]
            total += ca * cb * 2.0 * math.prod(math.factorial(k) for k in g) / math.factorial(sum(g) + 2)
        return total

    return np.array([[integral(p, q) for q in polys] for p in polys])


_GRAM6 = _quadratic_gram()


def allman_transform(xy: np.ndarray) -> np.ndarray:
    """Map [E, 12, 9] from corner (u, v, theta_z) x 3 to (u, v) at the 6 quadratic nodes; triangles [E, 3, 2] (m)."""
    ne = xy.shape[0]
    t = np.zeros((ne, 12, 9))
    for i in range(3):
        t[:, 2 * i, 3 * i] = 1.0
        t[:, 2 * i + 1, 3 * i + 1] = 1.0
    for k, (i, j) in enumerate(_SIDES):
        xij = xy[:, j, 0] - xy[:, i, 0]
        yij = xy[:, j, 1] - xy[:, i, 1]
        ru, rv = 6 + 2 * k, 7 + 2 * k
        for a in (i, j):
            t[:, ru, 3 * a] = 0.5
            t[:, rv, 3 * a + 1] = 0.5
        t[:, ru, 3 * i + 2], t[:, ru, 3 * j + 2] = -yij / 8.0, yij / 8.0
        t[:, rv, 3 * i + 2], t[:, rv, 3 * j + 2] = xij / 8.0, -xij / 8.0
    return t


def strain_matrices(xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Strain-displacement matrices B [E, 3 gauss, 3, 9] (1/m, 1 for theta_z) at the side midpoints and areas [E] (m^2).

    Strain order (eps_xx, eps_yy, gamma_xy), engineering shear.
    """
    bq, area = quadratic_gradient_operator(xy)
    return np.matmul(bq, allman_transform(xy)[:, None]), area


def membrane_stiffness(xy: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Element stiffness [E, 9, 9] (N/m, N, N m) of triangles [E, 3, 2] (m); membrane stiffness h Q [E, 3, 3] (N/m)."""
    b, area = strain_matrices(xy)
    ab = np.matmul(a[:, None], b)  # [E, 3, 3, 9]
    return np.matmul(b.transpose(0, 1, 3, 2), ab).sum(axis=1) * (area / 3.0)[:, None, None]


def membrane_mass(xy: np.ndarray, mass_per_area: np.ndarray) -> np.ndarray:
    """Consistent in-plane mass [E, 9, 9] (kg, kg m, kg m^2) of triangles [E, 3, 2] with rho*h [E] (kg/m^2)."""
    area, _, _ = triangle_geometry(xy)
    t = allman_transform(xy)
    g12 = np.kron(_GRAM6, np.eye(2))  # (u, v) interleaved at the 6 nodes
    return np.matmul(t.transpose(0, 2, 1), np.matmul(g12, t)) * (mass_per_area * area)[:, None, None]
