"""Discrete Kirchhoff triangle (DKT) plate bending element, vectorized over elements.

Nodal degrees of freedom (3 per node): w (m), w_x = dw/dx, w_y = dw/dy (rad), in the global
x-y axes, so plate, beam and lumped mass share them without rotation matrices.

Stiffness: the rotations beta = (beta_x, beta_y) (the normal's slopes) are interpolated
quadratically on the 6-node triangle; the discrete Kirchhoff constraints fix them from the 9
nodal DOFs: beta = grad w at the corners, and at each side midpoint the tangential component is
dw/ds of the cubic side interpolation of w while the normal component is the mean of the
corner values. Curvatures kappa = (beta_x,x, beta_y,y, beta_x,y + beta_y,x) are linear, so the
3-point side-midpoint rule integrates kappa^T D kappa exactly.

Mass: consistent mass of w interpolated by the reduced cubic Hermite triangle (the 9 nodal
DOFs; the cubic's centroid value follows the rule exact for quadratics), written in the
Bernstein basis so that the element Gram matrix is a constant times the area. Along each side
this w is the same cubic Hermite curve that the DKT constraints use.
"""

from __future__ import annotations

import math

import numpy as np

from romams_core.errors import InputError

# Cubic Bernstein multi-indices (a1, a2, a3): vertices, side points, centroid.
_ALPHA = np.array(
    [[3, 0, 0], [0, 3, 0], [0, 0, 3], [2, 1, 0], [1, 2, 0], [0, 2, 1], [0, 1, 2], [1, 0, 2], [2, 0, 1], [1, 1, 1]]
)


def _bernstein_gram() -> np.ndarray:
    """Integral of B_a B_b over a triangle of unit area [10, 10] (dimensionless)."""
    f = np.vectorize(math.factorial)
    fa = np.prod(f(_ALPHA), axis=1)
    s = _ALPHA[:, None, :] + _ALPHA[None, :, :]
    # int L^g dA = 2 A g! / (|g| + 2)!, B_a = 3!/a! L^a
    return 36.0 / (fa[:, None] * fa[None, :]) * 2.0 * np.prod(f(s), axis=2) / math.factorial(8)


_GRAM = _bernstein_gram()


def triangle_geometry(xy: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Areas [E] (m^2) and area-coordinate gradients dL/dx [E, 3], dL/dy [E, 3] (1/m) of triangles [E, 3, 2]."""
    x, y = xy[..., 0], xy[..., 1]
    b = np.stack([y[:, 1] - y[:, 2], y[:, 2] - y[:, 0], y[:, 0] - y[:, 1]], axis=1)
    c = np.stack([x[:, 2] - x[:, 1], x[:, 0] - x[:, 2], x[:, 1] - x[:, 0]], axis=1)
    two_a = (x[:, 1] - x[:, 0]) * (y[:, 2] - y[:, 0]) - (x[:, 2] - x[:, 0]) * (y[:, 1] - y[:, 0])
    if np.any(two_a <= 0.0):
        raise InputError("elements", "triangles must be counter-clockwise with positive area")
    return 0.5 * two_a, b / two_a[:, None], c / two_a[:, None]


# sides (i, j) of the midside nodes 4, 5, 6
_SIDES = ((0, 1), (1, 2), (2, 0))


def _constraint_matrix(xy: np.ndarray) -> np.ndarray:
    """Map from the 9 element DOFs to beta at the 6 quadratic nodes [E, 12, 9]."""
    ne = xy.shape[0]
    t = np.zeros((ne, 12, 9))
    for i in range(3):  # corners: beta = grad w
        t[:, 2 * i, 3 * i + 1] = 1.0
        t[:, 2 * i + 1, 3 * i + 2] = 1.0
    for k, (i, j) in enumerate(_SIDES):
        d = xy[:, j] - xy[:, i]
        length = np.linalg.norm(d, axis=1)
        s = d / length[:, None]
        rows = slice(6 + 2 * k, 8 + 2 * k)
        coef_w = 1.5 / length[:, None] * s  # [E, 2]
        t[:, rows, 3 * i] = -coef_w
        t[:, rows, 3 * j] = coef_w
        g = 0.5 * np.eye(2)[None] - 0.75 * s[:, :, None] * s[:, None, :]  # [E, 2, 2]
        t[:, rows, 3 * i + 1 : 3 * i + 3] = g
        t[:, rows, 3 * j + 1 : 3 * j + 3] = g
    return t


def quadratic_dn(lam: np.ndarray) -> np.ndarray:
    """dN/dL [6, 3] of the 6-node quadratic triangle at area coordinates lam [3] (nodes 4-6 on sides 12, 23, 31)."""
    l1, l2, l3 = lam
    return np.array(
        [
            [4 * l1 - 1, 0, 0],
            [0, 4 * l2 - 1, 0],
            [0, 0, 4 * l3 - 1],
            [4 * l2, 4 * l1, 0],
            [0, 4 * l3, 4 * l2],
            [4 * l3, 0, 4 * l1],
        ],
        dtype=float,
    )


_GAUSS = np.array([[0.5, 0.5, 0.0], [0.0, 0.5, 0.5], [0.5, 0.0, 0.5]])
# The 6-node order in the constraint matrix is corners, then midsides of (1,2), (2,3), (3,1): same as quadratic_dn.
_DN_GAUSS = np.stack([quadratic_dn(g) for g in _GAUSS])  # [3, 6, 3]
DN_MIDSIDES_T = _DN_GAUSS.transpose(0, 2, 1)  # [3 gauss, 3 L, 6 nodes]


def quadratic_gradient_operator(xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Symmetric-gradient operator [E, 3 gauss, 3, 12] (1/m) of a 6-node quadratic 2-component field (nodes x, y
    interleaved) at the side midpoints: rows (d/dx of x, d/dy of y, d/dy of x + d/dx of y); and areas [E] (m^2)."""
    area, dldx, dldy = triangle_geometry(xy)
    nx = np.matmul(dldx, DN_MIDSIDES_T).transpose(1, 0, 2)  # [E, 3 gauss, 6 nodes]
    ny = np.matmul(dldy, DN_MIDSIDES_T).transpose(1, 0, 2)
    bq = np.zeros(xy.shape[:1] + (3, 3, 12))
    bq[:, :, 0, 0::2] = nx
    bq[:, :, 1, 1::2] = ny
    bq[:, :, 2, 0::2] = ny
    bq[:, :, 2, 1::2] = nx
    return bq, area


def curvature_matrices(xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Curvature-displacement matrices B [E, 3 gauss, 3, 9] (1/m) at the side midpoints and areas [E] (m^2)."""
    bq, area = quadratic_gradient_operator(xy)
    return np.matmul(bq, _constraint_matrix(xy)[:, None]), area


def dkt_stiffness(xy: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Element stiffness [E, 9, 9] (SI) of triangles [E, 3, 2] (m) with bending stiffness D [E, 3, 3] (N m)."""
    b, area = curvature_matrices(xy)
    db = np.matmul(d[:, None], b)  # [E, 3, 3, 9]
    return np.matmul(b.transpose(0, 1, 3, 2), db).sum(axis=1) * (area / 3.0)[:, None, None]


def bernstein_coefficients(xy: np.ndarray) -> np.ndarray:
    """Map from the 9 element DOFs to the 10 cubic Bernstein coefficients of w [E, 10, 9]."""
    ne = xy.shape[0]
    c = np.zeros((ne, 10, 9))
    centroid = xy.mean(axis=1)
    for i in range(3):
        c[:, i, 3 * i] = 1.0
    # side control points b_(2,1,0) = w_i + grad w_i . (a_j - a_i) / 3 and the like
    side_pts = {3: (0, 1), 4: (1, 0), 5: (1, 2), 6: (2, 1), 7: (2, 0), 8: (0, 2)}
    for row, (i, j) in side_pts.items():
        d = (xy[:, j] - xy[:, i]) / 3.0
        c[:, row, 3 * i] = 1.0
        c[:, row, 3 * i + 1 : 3 * i + 3] = d
    for i in range(3):  # centroid: b111 = sum(w)/3 + sum(grad w_i . (c - a_i))/4
        c[:, 9, 3 * i] = 1.0 / 3.0
        c[:, 9, 3 * i + 1 : 3 * i + 3] = 0.25 * (centroid - xy[:, i])
    return c


def bernstein_values(lam: np.ndarray) -> np.ndarray:
    """Cubic Bernstein polynomials [P, 10] at area coordinates lam [P, 3]."""
    lam = np.asarray(lam, dtype=float)
    coef = np.array([6.0 / np.prod([math.factorial(int(a)) for a in al]) for al in _ALPHA])
    return coef[None, :] * np.prod(lam[:, None, :] ** _ALPHA[None, :, :], axis=2)


def cubic_mass(xy: np.ndarray, mass_per_area: np.ndarray) -> np.ndarray:
    """Consistent element mass [E, 9, 9] (kg, kg m, kg m^2) of triangles [E, 3, 2] with rho*h [E] (kg/m^2)."""
    area, _, _ = triangle_geometry(xy)
    c = bernstein_coefficients(xy)
    return np.matmul(c.transpose(0, 2, 1), np.matmul(_GRAM, c)) * (mass_per_area * area)[:, None, None]
