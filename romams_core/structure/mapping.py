"""Interpolation of mode shapes from scattered FE nodes onto the standard mesh."""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CloughTocher2DInterpolator, LinearNDInterpolator, NearestNDInterpolator
from scipy.spatial import Delaunay

from romams_core.errors import InputError
from romams_core.mesh import StandardMesh


def map_to_mesh(points_xy: np.ndarray, values: np.ndarray, mesh: StandardMesh, smooth: bool = True) -> np.ndarray:
    """Interpolate nodal values [P, k] at FE points [P, 2] (m) onto the standard mesh nodes -> [N, k].

    Inside the convex hull of the FE points a C1 Clough-Tocher (``smooth=True``) or piecewise
    linear interpolant is used; standard-mesh nodes outside the hull (round-off at the planform
    edges, or an FE model smaller than the planform) take the nearest FE node's value.
    """
    pts = np.asarray(points_xy, dtype=float)
    vals = np.asarray(values, dtype=float)
    squeeze = vals.ndim == 1
    if squeeze:
        vals = vals[:, None]
    if pts.ndim != 2 or pts.shape[1] != 2:
        raise InputError("points_xy", f"expected shape [P, 2], got {pts.shape}")
    if vals.shape[0] != pts.shape[0]:
        raise InputError("values", f"expected {pts.shape[0]} rows (one per point), got {vals.shape[0]}")
    if not (np.all(np.isfinite(pts)) and np.all(np.isfinite(vals))):
        raise InputError("values", "points and values must be finite")
    target = np.column_stack([mesh.x, mesh.y])
    tri = Delaunay(pts)
    interp = CloughTocher2DInterpolator(tri, vals) if smooth else LinearNDInterpolator(tri, vals)
    out = np.asarray(interp(target), dtype=float).reshape(target.shape[0], vals.shape[1])
    bad = ~np.all(np.isfinite(out), axis=1)
    if np.any(bad):
        out[bad] = NearestNDInterpolator(pts, vals)(target[bad]).reshape(int(bad.sum()), vals.shape[1])
    return out[:, 0] if squeeze else out
