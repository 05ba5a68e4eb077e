"""The 3-D TSD grid's steady far field (``romams_core.aero.tsd.far_field``): the potential of the wing's
circulation against its own derivatives, the Prandtl-Glauert equation and the 2-D vortex; and what it is for,
a steady lift that no longer depends on where the lateral face is."""

from __future__ import annotations

import math

import numpy as np
import pytest

from romams_core.aero.tsd import far_field as ff
from romams_core.aero.tsd.coefficients import tsd_coefficients
from romams_core.aero.tsd.flow import TsdFlow
from romams_core.aero.tsd.grid import GridSpec, wing_grid
from romams_core.aero.tsd.solver import TsdSolver
from romams_core.errors import InputError

AGARD = (1.364, 0.66, math.tan(math.radians(46.7)))  # semispan, taper (c_ref units), tan of the LE sweep
BETA = math.sqrt(1.0 - 0.7 ** 2)


def _points(n: int = 24, seed: int = 0) -> np.ndarray:
    """Points away from the sheet (|z| >= 0.3 c_ref), around and beyond the AGARD planform."""
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(-3.0, 6.0, n), rng.uniform(-4.0, 4.0, n),
                            rng.uniform(0.3, 3.0, n) * rng.choice([-1.0, 1.0], n)])


@pytest.mark.parametrize("root", ["symmetric", "antisymmetric", "open"])
def test_sheet_gradients_are_the_potentials_derivatives(root: str) -> None:
    g = wing_grid(*AGARD, GridSpec(), root=root)
    jumps = np.random.default_rng(1).normal(size=g.shape[1]) * g.strips
    pts = _points()
    h = 1e-4
    for axis in range(3):
        e = np.zeros(3)
        e[axis] = h
        fd = (ff.sheet_potential(g, pts + e, BETA) - ff.sheet_potential(g, pts - e, BETA)) @ jumps / (2 * h)
        an = ff.sheet_gradient(g, pts, axis, BETA) @ jumps
        assert np.max(np.abs(fd - an)) < 1e-6 * np.max(np.abs(an))  # central difference error ~ h^2


def test_sheet_potential_solves_the_prandtl_glauert_equation() -> None:
    g = wing_grid(*AGARD, GridSpec())
    jumps = np.random.default_rng(2).normal(size=g.shape[1]) * g.strips
    pts, h = _points(seed=3), 2e-3
    phi0 = ff.sheet_potential(g, pts, BETA) @ jumps
    lap = np.zeros(len(pts))
    for axis, w in ((0, BETA ** 2), (1, 1.0), (2, 1.0)):
        e = np.zeros(3)
        e[axis] = h
        lap += w * (ff.sheet_potential(g, pts + e, BETA) @ jumps - 2 * phi0
                    + ff.sheet_potential(g, pts - e, BETA) @ jumps) / h ** 2
    scale = np.max(np.abs(ff.sheet_gradient(g, pts, 2, BETA) @ jumps))  # 1/c_ref, at distances of order 1
    assert np.max(np.abs(lap)) < 2e-4 * scale  # the second differences' truncation (~h^2) is the floor


def test_a_long_unswept_wing_has_the_2d_compressible_vortex_far_field() -> None:
    """Far from the tips of a rectangular wing with one circulation, the field is the 2-D vortex at c/4:
    phi = Gamma / (2 pi) atan2(beta z, -(x - 1/4)), which the 2-D grid prescribes (``TsdFlow._vortex_far_field``)."""
    g = wing_grid(400.0, 1.0, 0.0, GridSpec(n_span=1200, span_cluster=0.0))
    jumps = np.where(g.strips, 0.8, 0.0)
    x = np.array([-3.0, -1.0, 0.6, 2.0, 5.0, 0.25])
    z = np.array([1.0, -2.0, 1.5, -0.7, 3.0, 2.0])
    pts = np.column_stack([x, np.full(x.size, 1.0), z])  # 1 c_ref from the root's symmetry plane
    xx, r2 = x - 0.25, (x - 0.25) ** 2 + (BETA * z) ** 2
    k_ = 0.8 / (2 * math.pi)
    # plus the downwash of the two tip vortices, semi-infinite from x = 1/4, 400 c_ref to either side (PG scaled)
    tips = -2.0 * 0.8 / (4 * math.pi * 400.0) * (1.0 + xx / BETA / np.hypot(xx / BETA, 400.0))
    want = {0: k_ * BETA * z / r2, 2: -k_ * BETA * xx / r2 + tips, 1: np.zeros(x.size)}
    for axis in range(3):
        got = ff.sheet_gradient(g, pts, axis, BETA) @ jumps
        assert np.max(np.abs(got - want[axis])) < 1e-4 * np.max(np.abs(want[2]))


def _lift(far_field: str, **spec: float) -> float:
    """Steady sum Gamma dy (U c_ref^2) of the flat AGARD planform at 1 deg incidence, M 0.5, on a coarse grid."""
    g = wing_grid(*AGARD, GridSpec(**spec).scaled(0.625))
    f = TsdFlow(g, tsd_coefficients(0.5), far_field=far_field)
    f.w_up[...] = np.where(g.wing, -math.radians(1.0), 0.0)
    f.w_lo[...] = f.w_up
    res = f.solve_steady(dt=0.02, max_steps=4000, tol=2e-5)
    assert res.converged
    return float(np.sum(f.gamma_te() * np.diff(g.yf)))


def test_wake_far_field_removes_the_lateral_faces_wall_effect() -> None:
    """With zero-gradient (slip-wall) outer faces a lateral face 1.5 semispans beyond the tip (the default until
    2026-12-05) adds lift as a tunnel wall does; with the wake's potential on them the lift hardly moves when that
    face is moved to 3."""
    near, far = {"y_outboard": 2.5, "n_outboard": 10}, {"y_outboard": 4.0, "n_outboard": 14}
    plain, plain_far = _lift("plain", **near), _lift("plain", **far)
    wake, wake_far = _lift("wake", **near), _lift("wake", **far)
    assert plain / plain_far - 1.0 > 0.01  # measured +1.6 %
    assert abs(wake / wake_far - 1.0) < 0.004  # measured +0.14 %
    assert 0.0 < plain / wake - 1.0 < 0.05  # the walls' excess on that grid, measured +2.4 %


def test_far_field_is_checked() -> None:
    with pytest.raises(InputError, match="far_field"):
        TsdSolver(far_field="walls")
    with pytest.raises(InputError, match="far_field"):
        TsdFlow(wing_grid(*AGARD, GridSpec()), tsd_coefficients(0.5), far_field="")


@pytest.mark.parametrize("root", ["symmetric", "open"])
def test_compressed_face_gradients_are_the_sheets(root: str) -> None:
    """The flow's far-field arrays (truncated SVD factors) equal the sheet's gradients at the face points: phi_x at
    the upstream and downstream faces' nodes, phi_z at the bottom and top faces, phi_y at the lateral face (and, for
    a free wing, the face below the root; zero on a symmetry plane)."""
    g = wing_grid(*AGARD, GridSpec(), root=root)
    ni, nj, nk = g.shape
    jumps = np.random.default_rng(4).normal(size=nj) * g.strips
    far_u, far_w, far_v = np.zeros((2, nj, nk)), np.zeros((2, ni, nj)), np.zeros((2, ni, nk))
    ff.WakeFarField.of(g, BETA).update(jumps, far_u, far_w, far_v)
    j, k, i = nj - 3, nk - 2, ni // 2
    xle, c = g.x_le(g.yc[j]), g.chord(g.yc[j])
    want_u = ff.sheet_gradient(g, np.array([[xle + c * g.xf[-1], g.yc[j], g.zc[k]]]), 0, BETA) @ jumps
    want_w = ff.sheet_gradient(g, np.array([[xle + c * g.xc[i], g.yc[j], g.zf[0]]]), 2, BETA) @ jumps
    y = g.yf[-1]
    want_v = ff.sheet_gradient(g, np.array([[g.x_le(y) + g.chord(y) * g.xc[i], y, g.zc[k]]]), 1, BETA) @ jumps
    scale = np.abs(far_w).max()
    assert abs(far_u[1, j, k] - want_u[0]) < 1e-7 * scale
    assert abs(far_w[0, i, j] - want_w[0]) < 1e-7 * scale
    assert abs(far_v[1, i, k] - want_v[0]) < 1e-7 * scale
    assert (np.abs(far_v[0]).max() > 1e-9 * scale) == (root == "open")  # (round-off of the SVD elsewhere)
