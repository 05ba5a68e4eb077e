"""2-D checks of the TSD solver (romams_core.aero.tsd): lift against compressible thin-airfoil theory, the transonic
NACA 0012 against an independent discretization and TSFOIL2, consistency of the factored operators with the
residual, the Engquist-Osher switch, and pitching against linear theory. Numbers in docstrings are measured values;
docs/tsd_2d_validation.md discusses them."""

import math

import numpy as np
import pytest

from benchmarks.validate_tsd_2d import (
    BASE_SPEC,
    CT6,
    TSFOIL_N0012,
    dlm_strip,
    pitching_section,
    reference_naca0012,
    reference_on_tsfoil_mesh,
    steady_section,
)
from romams_core.aero.tsd import kernels
from romams_core.aero.tsd.coefficients import tsd_coefficients
from romams_core.aero.tsd.flow import TsdFlow
from romams_core.aero.tsd.grid import GridSpec, airfoil_grid, wing_grid

#: the validation grid at half resolution: 25 uniform chord cells, dz0 0.04, 1666 nodes (dt 0.04 is stable on it)
COARSE = BASE_SPEC.scaled(0.5)


@pytest.fixture(scope="module")
def naca0012():
    """NACA 0012, M 0.75, alpha 2 deg on the coarse grid (converged in about 4100 steps, 5 s)."""
    return steady_section(COARSE, 0.75, 2.0, "naca4", 0.12, dt=0.04)


def test_flat_plate_lift_matches_compressible_thin_airfoil_theory():
    """M 0.5, alpha 1 deg on the 50-cell grid: CL 0.12743 against 2 pi alpha / beta = 0.12663 (+0.6 %; the 25-cell
    grid gives +1.8 %), converged in 4263 steps."""
    row = steady_section(BASE_SPEC, 0.5, 1.0, None, 0.0, dt=0.02)
    theory = 2.0 * math.pi * math.radians(1.0) / math.sqrt(1.0 - 0.25)
    assert row["converged"]
    assert row["cl"] == pytest.approx(theory, rel=0.02)
    assert math.isnan(row["x_shock"])  # subcritical: no shock


def test_naca0012_transonic_agrees_with_an_independent_discretization(naca0012):
    """The AF time march converges to the same flow as the vertex-centred Newton solver of the benchmark
    (reference_steady_tsd: another discretization of the same equation, far field and Kutta condition).
    Measured: CL 0.4494 (AF, 25 cells) and 0.4438 (reference, 50 cells), upper shock 0.436 and 0.434; with refinement
    both approach CL 0.455, shock 0.445 (AF 100 cells: 0.4527, reference 200 cells: 0.4528)."""
    assert naca0012["converged"]
    ref = reference_naca0012()
    assert ref["residual"] < 1e-9
    assert naca0012["cl"] == pytest.approx(ref["cl"], rel=0.03)
    assert naca0012["x_shock"] == pytest.approx(ref["x_shock"], abs=0.02)
    assert naca0012["cl"] == pytest.approx(0.455, rel=0.03)


def test_naca0012_against_tsfoil2_gap_is_the_similarity_scaling(naca0012):
    """TSFOIL2 (pyTSFoil example N0012): CL 0.5306, sonic point of the upper shock x = 0.547. Our equation gives CL
    0.45 (-15 %) with the shock at 0.44 (0.11 c forward): TSFOIL uses Krupp's similarity scaling, which in chord
    units is a stronger nonlinearity (F = -1.2 M^1.75 instead of -1.2 M^2) and slopes scaled by M^-0.25, and its
    49-point chord mesh with point slopes at the leading edge. That equation on that mesh, solved by the reference
    solver, reproduces TSFOIL: CL 0.5322 (+0.3 %), shock 0.541. The tolerances below are what the solver honestly
    meets against TSFOIL; the check of the scheme itself is the test against the reference above."""
    assert naca0012["cl"] == pytest.approx(TSFOIL_N0012["cl"], rel=0.17)
    assert naca0012["x_shock"] == pytest.approx(TSFOIL_N0012["x_sonic"], abs=0.13)
    assert naca0012["cp_star"] == pytest.approx(-0.648, abs=1e-3)  # linear Cp* of the M^2 sets (TSFOIL: -0.603)
    krupp = reference_on_tsfoil_mesh()
    assert krupp["cp_star"] == pytest.approx(TSFOIL_N0012["cp_star"], abs=1e-5)
    assert krupp["cl"] == pytest.approx(TSFOIL_N0012["cl"], rel=0.01)
    assert krupp["x_shock"] == pytest.approx(TSFOIL_N0012["x_sonic"], abs=0.01)


def test_naca0012_nlr_set_meets_tsfoil2():
    """With the "nlr" coefficient set, whose sonic velocity is within 3 % of the isentropic critical speed (the Ames
    set's is 14 % above it at M 0.75), the issue's TSFOIL2 criterion holds: measured CL 0.5154 (-2.9 %) and shock
    0.5425 on 25 cells; 0.5216 / 0.551 on 50; the reference solver 0.513 / 0.525 / 0.533 on 50 / 100 / 200 cells
    (docs/tsd_2d_validation.md 3.2). Both discretizations of the nlr equation agree within 3 %."""
    u_exact = math.sqrt((2.0 + 0.4 * 0.75 ** 2) / (2.4 * 0.75 ** 2)) - 1.0  # isentropic sonic u / U at M 0.75
    assert tsd_coefficients(0.75, "nlr").u_star == pytest.approx(u_exact, rel=0.03)
    assert tsd_coefficients(0.75, "ames").u_star > 1.1 * u_exact
    row = steady_section(COARSE, 0.75, 2.0, "naca4", 0.12, dt=0.04, coefficients="nlr")
    assert row["converged"]
    assert row["cl"] == pytest.approx(TSFOIL_N0012["cl"], rel=0.05)
    assert row["x_shock"] == pytest.approx(TSFOIL_N0012["x_sonic"], abs=0.03)
    ref = reference_naca0012(F=tsd_coefficients(0.75, "nlr").F)
    assert ref["residual"] < 1e-9
    assert ref["cl"] == pytest.approx(TSFOIL_N0012["cl"], rel=0.05)
    assert ref["cl"] == pytest.approx(row["cl"], rel=0.03)
    assert ref["x_shock"] == pytest.approx(row["x_shock"], abs=0.02)


def test_eo_switch_gives_a_smooth_sonic_line_and_a_compressive_shock(naca0012):
    """Upper surface of the NACA 0012 (coarse grid): one supersonic zone from the nose; Cp rises through Cp* in a
    compression of 0.96 over three cells at x = 0.38-0.50, and behind x = 0.1 no drop of Cp between neighbouring
    nodes exceeds 0.04 (no expansion shock). Off the surface (z = 0.13, 0.22, 0.34, where the sonic line is clear
    of the nose singularity) u crosses u* in the same step as on the approach (0.11 / 0.08 / 0.06 against
    0.16 / 0.10 / 0.06 one face upstream) and falls through u* at the shock by 0.30 / 0.25 / 0.12."""
    flow = naca0012["_flow"]
    g = flow.grid
    w = g.wing[:, 0]
    x, cp = g.xc[w], flow.surface_cp()[0][w, 0]
    sup = cp < naca0012["cp_star"]
    first, last = np.flatnonzero(sup)[[0, -1]]
    assert x[first] < 0.1 and sup[first:last + 1].all()
    jump = cp[last + 2] - cp[last - 1]
    assert jump > 0.8
    drops = -np.diff(cp)[x[1:] > 0.1]
    assert drops.max() < 0.1 * jump
    us = flow.coef.u_star
    lines = 0
    for k in range(g.k0 + 3, g.zc.size):
        u = np.diff(flow.phi[:, 0, k]) / np.diff(g.xc)
        if not (u > us).any():
            continue
        a, b = np.flatnonzero(u > us)[[0, -1]]
        assert (u[a:b + 1] > us).all()  # one supersonic stretch per line
        accel, before = u[a] - u[a - 1], u[a - 1] - u[a - 2]
        shock = u[b + 1] - u[b]
        assert 0.0 < accel < 1.5 * max(before, 0.0) + 1e-3  # continuous through the sonic point
        assert shock < -accel  # compressive jump at the shock, steeper than the sonic crossing
        lines += 1
    assert lines >= 3


# ------------------------------------------------------------------------------------- Jacobian consistency
def _jacobians(grid, coef_name, amp, seed=0):
    """Finite-difference Jacobian of the residual (rhs output) and Lxi + Leta + Lzeta - 2 I from the line solves."""
    f = TsdFlow(grid, tsd_coefficients(0.8, coef_name))
    rng = np.random.default_rng(seed)
    f.phi[...] = amp * rng.standard_normal(grid.shape)
    for lev in f.levels:
        lev[...] = f.phi + 0.2 * amp * rng.standard_normal(grid.shape)
    f.w_up[grid.wing] = -0.03
    f.w_lo[grid.wing] = 0.02
    tc = f._tc(2, 0.3)
    g = grid

    def rhs(phi):
        out = np.zeros(g.shape)
        f.residual(tc, phi, out)
        return out.ravel()

    n = g.n_points
    r0 = rhs(f.phi)
    h = 1e-6 * max(amp, 1e-3)
    jfd = np.empty((n, n))
    for p in range(n):
        ph = f.phi.copy().ravel()
        ph[p] += h
        jfd[:, p] = (rhs(ph.reshape(g.shape)) - r0) / h

    def factor(solve):
        inv = np.empty((n, n))
        for p in range(n):
            w = np.zeros(n)
            w[p] = 1.0
            w = w.reshape(g.shape)
            solve(w)
            inv[:, p] = w.ravel()
        return np.linalg.inv(inv)

    lx = factor(lambda w: kernels.solve_xi(f.phi, w, tc, f._co, g.xc, g.xf, f._cj, f._xiy_xf, f.sponge))
    le = factor(lambda w: kernels.solve_eta(f.phi, w, tc, f._co, g.xc, g.yc, g.yf, f._cj, f._cyf, g.lateral_far,
                                            g.root_code, f._c_root))
    lz = factor(lambda w: kernels.solve_zeta(w, tc, f._co, g.zc, g.zf, f._wing, g.k0))
    idx = np.array(np.unravel_index(np.arange(n), g.shape)).T
    u = np.diff(f.phi, axis=0) / np.diff(g.xc)[:, None, None] / f._cj[None, :, None]
    return -jfd, lx + le + lz - 2.0 * np.eye(n), idx, float(np.mean(u > f.coef.u_star))


TINY = GridSpec(n_chord=8, n_upstream=3, n_downstream=3, n_z=4, dz0=0.05, z_max=2.0, n_span=3, n_outboard=2)


def test_factors_are_the_jacobian_in_2d():
    """2-D, M 0.8, random phi of amplitude 0.05 (a third of the faces supersonic, so the EO switch and the (i-2)
    band are exercised): the factored operator equals -dN/dphi (scaled) to 8e-8 of its largest entry (the finite
    difference error) on every row except the far-field rows i = 0 and ni-1, whose flux g(-kappa phi_t) is
    linearized without its F term (2e-3)."""
    jac, fac, idx, supersonic = _jacobians(airfoil_grid(TINY), "ames", 0.05)
    assert 0.1 < supersonic < 0.9
    ni = airfoil_grid(TINY).shape[0]
    rows = (idx[:, 0] > 0) & (idx[:, 0] < ni - 1)
    scale = np.abs(jac).max()
    assert np.abs(jac - fac)[rows].max() < 1e-5 * scale
    assert np.abs(jac - fac).max() < 1e-2 * scale


def test_factors_are_the_jacobian_in_3d_without_cross_terms():
    """3-D rectangular wing (no metric cross terms) with the 2-D coefficient set (G = H = 0): the three factors
    carry the whole Jacobian, EO switch included (random phi 0.05): 8e-8 of its largest entry off the far-field
    rows i = 0 and ni-1. (With the Ames set the G phi_y^2 and H phi_x phi_y terms, explicit, add 1.5e-3 at this
    amplitude.)"""
    g = wing_grid(1.5, 1.0, 0.0, TINY)
    jac, fac, idx, supersonic = _jacobians(g, "2d", 0.05)
    assert 0.1 < supersonic < 0.9
    rows = (idx[:, 0] > 0) & (idx[:, 0] < g.shape[0] - 1)
    assert np.abs(jac - fac)[rows].max() < 1e-5 * np.abs(jac).max()


def test_factors_carry_the_line_entries_of_the_swept_3d_jacobian():
    """Swept, tapered wing, Ames coefficients, small random phi (1e-4: the G and H terms are then negligible). The
    cross-derivative terms (phi_xi_eta from the sheared mapping) stay on the right-hand side on purpose, so only
    the entries the factors carry are compared (diagonal and the direct neighbours along each line), off the
    boundary rows. Along z the factor is exact (2e-10 of the largest entry); on the xi and eta neighbours and the
    diagonal the explicit metric cross terms, which reach the same nodes through the central differences of the
    sheared mapping, leave up to 5.3e-3 (xi), 3.3e-4 (eta) and 8.7e-4 (diagonal)."""
    g = wing_grid(1.5, 0.6, 0.8, TINY)
    jac, fac, idx, _ = _jacobians(g, "ames", 1e-4)
    ni, nj, nk = g.shape
    rows = (idx[:, 0] > 0) & (idx[:, 0] < ni - 1) & (idx[:, 1] < nj - 1) & (idx[:, 2] > 0) & (idx[:, 2] < nk - 1)
    step = np.abs(idx[:, None, :] - idx[None, :, :])
    line = step.sum(-1) <= 1
    along_z = (step[..., 2] == 1) & (step[..., :2].sum(-1) == 0)
    scale = np.abs(jac).max()
    diff = np.abs(jac - fac)
    assert diff[rows[:, None] & along_z].max() < 1e-6 * scale
    assert diff[rows[:, None] & line].max() < 1e-2 * scale


# ------------------------------------------------------------------------------------------------ unsteady
def test_pitching_flat_plate_follows_linear_theory():
    """Flat plate pitching about c/4 at the CT6 conditions (M 0.796, k 0.202, 1 deg), 50 chord cells, 4 cycles of
    800 steps, first harmonic of the last cycle, against the doublet-lattice root strip of an AR 40 wing (linear
    theory). Measured: CL_alpha 5.710 at -10.5 deg against 5.733 at -9.2 deg (-0.4 %, -1.2 deg); CM_alpha (nose up,
    about c/4) 0.692 at -101.8 deg against 0.671 at -102.9 deg (+3.1 %, +1.1 deg). Before the wake delay was
    measured from the last wing node (docs/transonic.md 7.3): CL +2.1 %, -1.3 deg and CM +11 %, -1.6 deg."""
    tsd = pitching_section(None, 0.0, spec=BASE_SPEC, cycles=4, steps_per_cycle=800)
    lin = dlm_strip(CT6["mach"], CT6["k"], CT6["x_pivot"])
    assert tsd["cl_alpha_mag"] == pytest.approx(lin["cl_alpha_mag"], rel=0.04)
    assert tsd["cl_alpha_phase_deg"] == pytest.approx(lin["cl_alpha_phase_deg"], abs=3.0)
    assert tsd["cm_alpha_mag"] == pytest.approx(lin["cm_alpha_mag"], rel=0.15)
    assert tsd["cm_alpha_phase_deg"] == pytest.approx(lin["cm_alpha_phase_deg"], abs=4.0)


@pytest.mark.parametrize("mode", ["plunge", "pitch"])
def test_high_frequency_flat_plate_follows_linear_theory(mode):
    """2-D flat plate, M 0.5, k 1 (semichord), plunge or pitch about c/4, against the DLM root strip of an AR 40 wing
    (benchmarks.tsd_2d_harmonic; 17,520 nodes, 6 cycles, about 5 s of TSD each). Measured: CL 1.010 / -1.7 deg
    (plunge) and 1.013 / -2.7 deg (pitch) of the strip's. Before the wake delay was measured from the last wing node
    (docs/transonic.md 7.3), the trailing edge carried a spurious pressure jump and the lift was 1.066 / -2.7 deg and
    1.064 / -2.9 deg; 3 % separates the two. The phase allows 4 deg: the strip itself differs from a 2-D Possio
    solution by 3.4 deg here (the TSD lies between the two)."""
    from benchmarks.tsd_2d_harmonic import compare

    row = compare(0.5, 1.0, mode)
    assert row["magnitude_ratio"] == pytest.approx(1.0, abs=0.03)
    assert abs(row["phase_deg"]) < 4.0
