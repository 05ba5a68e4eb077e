"""Splines from structural nodes to aerodynamic points, like Nastran's SPLINE1 (surface) and SPLINE2 (beam).

- :func:`surface_spline`: the infinite-plate (thin-plate, Harder-Desmarais) spline
  w(x, y) = a0 + a1 x + a2 y + sum_i F_i r_i^2 ln r_i^2 through the out-of-plane displacements of scattered
  nodes (plate models). It interpolates: at a node it returns the node's value.
- :func:`beam_spline`: a stick model's nodes on a (polyline) beam axis carry a displacement w and rotations
  (theta_x, theta_y) (Nastran T3, R1, R2 in the basic frame). Along the axis w is a cubic Hermite curve whose
  end slopes come from the rotations (dw/ds = theta_x e_y - theta_y e_x for the axis direction e), the
  rotations vary linearly, and each aerodynamic point moves with the rigid chordwise section of its axis point:
  w = w_axis + theta_x r_y - theta_y r_x (r: the point's offset from the axis point). Beyond the axis ends the
  end section is extended rigidly.
Coordinates in m, rotations in rad; values [P] or [P, k] for k modes.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import RBFInterpolator

from romams_core.errors import InputError

#: above this many nodes the surface spline is solved locally on the nearest nodes of each point
_DENSE_MAX = 2500
_NEIGHBOURS = 300


def surface_spline(points_xy: np.ndarray, values: np.ndarray, targets_xy: np.ndarray) -> np.ndarray:
    """Infinite-plate spline of nodal values [P, k] at points [P, 2] (m), evaluated at targets [T, 2] -> [T, k]."""
    pts = np.asarray(points_xy, dtype=float)
    vals = np.asarray(values, dtype=float)
    squeeze = vals.ndim == 1
    vals = vals[:, None] if squeeze else vals
    if pts.ndim != 2 or pts.shape[1] != 2 or vals.shape[0] != pts.shape[0]:
        raise InputError("points_xy", f"expected points [P, 2] and values [P, k], got {pts.shape} and {vals.shape}")
    centre = pts.mean(axis=0)
    scale = float(np.ptp(pts, axis=0).max()) or 1.0  # conditioning only: the spline is scale invariant
    neighbours = None if pts.shape[0] <= _DENSE_MAX else _NEIGHBOURS
    try:
        rbf = RBFInterpolator((pts - centre) / scale, vals, kernel="thin_plate_spline", degree=1,
                              neighbors=neighbours)
    except (np.linalg.LinAlgError, ValueError) as exc:
        raise InputError("nodes", f"the surface spline is singular ({exc}); nodes must be distinct in plane "
                                  "and not all on one line (a stick model needs the beam spline)") from None
    out = rbf((np.asarray(targets_xy, dtype=float) - centre) / scale)
    return out[:, 0] if squeeze else out


def _axis(points_xy: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Order of the nodes along the beam axis, their coordinate s (m) along its main direction, that direction."""
    centred = points_xy - points_xy.mean(axis=0)
    direction = np.linalg.svd(centred, full_matrices=False)[2][0]
    if direction[1] < 0:  # root to tip: +y
        direction = -direction
    s = centred @ direction
    order = np.argsort(s, kind="stable")
    if np.any(np.diff(s[order]) <= 1e-9 * max(float(np.ptp(s)), 1e-300)):
        raise InputError("nodes", "two beam nodes lie at the same station along the axis (leave one out with the "
                                  "GRID selection)")
    return order, s[order], direction


def beam_spline(points_xy: np.ndarray, w: np.ndarray, rotations: np.ndarray, targets_xy: np.ndarray) -> np.ndarray:
    """SPLINE2-like beam spline: w [P, k] and rotations [2, P, k] (theta_x, theta_y) at axis nodes [P, 2] (m)
    -> w at targets [T, 2] -> [T, k]."""
    pts = np.asarray(points_xy, dtype=float)
    w = np.asarray(w, dtype=float).reshape(pts.shape[0], -1)
    rot = np.asarray(rotations, dtype=float).reshape(2, pts.shape[0], -1)
    if pts.shape[0] < 2:
        raise InputError("nodes", "a beam spline needs at least 2 axis nodes")
    order, s, direction = _axis(pts)
    tgt = np.asarray(targets_xy, dtype=float)
    s_t = (tgt - pts.mean(axis=0)) @ direction
    pts, w, rot = pts[order], w[order], rot[:, order]
    j = np.clip(np.searchsorted(s, s_t) - 1, 0, s.size - 2)
    seg = pts[j + 1] - pts[j]
    length = np.linalg.norm(seg, axis=1)
    e = seg / length[:, None]
    u = np.clip(((tgt - pts[j]) * e).sum(axis=1) / length, 0.0, 1.0)  # position on the segment, 0..1
    p_axis = pts[j] + u[:, None] * seg
    r = tgt - p_axis  # offset from the axis point (includes the rigid extension past the ends)
    th = rot[:, j] * (1.0 - u)[None, :, None] + rot[:, j + 1] * u[None, :, None]  # [2, T, k]
    slope0 = rot[0, j] * e[:, 1:2] - rot[1, j] * e[:, 0:1]  # dw/ds at the segment ends, [T, k]
    slope1 = rot[0, j + 1] * e[:, 1:2] - rot[1, j + 1] * e[:, 0:1]
    u2, u3 = u * u, u * u * u
    h00, h10, h01, h11 = 2 * u3 - 3 * u2 + 1, u3 - 2 * u2 + u, -2 * u3 + 3 * u2, u3 - u2
    w_axis = (h00[:, None] * w[j] + h10[:, None] * (length[:, None] * slope0)
              + h01[:, None] * w[j + 1] + h11[:, None] * (length[:, None] * slope1))
    return w_axis + th[0] * r[:, 1:2] - th[1] * r[:, 0:1]


def is_stick(points_xy: np.ndarray, width_fraction: float = 0.02) -> bool:
    """True when nodes [P, 2] lie on one line (a stick model): spread across the main direction below
    ``width_fraction`` of the spread along it."""
    pts = np.asarray(points_xy, dtype=float)
    if pts.shape[0] < 2:
        return True
    sv = np.linalg.svd(pts - pts.mean(axis=0), compute_uv=False)
    return bool(sv.size < 2 or sv[1] <= width_fraction * sv[0])
