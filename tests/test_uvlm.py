"""Linear UVLM verification: steady lift slopes, Theodorsen, Wagner, convergence, compressibility, consistency."""

import math

import numpy as np
import pytest
from scipy.special import hankel2

from romams_core.aero.protocol import Cancelled, UnsteadySolver
from romams_core.aero.uvlm import (
    UvlmSolver,
    bdf2,
    build_uvlm,
    frequency_response,
    march,
    panel_forces_frequency,
    refine_mesh,
    substep_signals,
    uvlm_state_space,
)
from romams_core.mesh import Planform, standard_mesh


def _rect(ar: float, nc: int, ns: int):
    return standard_mesh(Planform(root_chord=1.0, tip_chord=1.0, semispan=ar / 2, n_chord=nc, n_span=ns))


def _cl_alpha(ar: float, nc: int, ns: int, mach: float = 0.0, wake: float = 50.0) -> float:
    """Steady CL_alpha (1/rad) of a flat rectangular wing from the k -> 0 GAC (pitch about the LE, lift shape 1)."""
    mesh = _rect(ar, nc, ns)
    shapes = np.column_stack([-mesh.x, np.ones(mesh.n_nodes)])  # h = -alpha x ; phi = 1 gives lift / q
    h = frequency_response(mesh, shapes, mach, [1e-6], dt_star=1.0 / nc, wake_chords=wake)
    return float(h[0, 1, 0].real) / mesh.planform.area


@pytest.mark.parametrize("ar, ref", [(2.0, 2.474), (6.0, 4.214), (20.0, 5.435)])
def test_steady_lift_slope_rectangular_wings(ar, ref):
    # converged ring-VLM / lifting-surface values of the reference notes, tolerance 3 %
    assert _cl_alpha(ar, 8, 16) == pytest.approx(ref, rel=0.03)


def test_lift_slope_converges_with_spanwise_panels():
    ref = 3.612  # AR 4
    errs = [abs(_cl_alpha(4.0, 8, ns) - ref) / ref for ns in (4, 8, 16)]
    assert errs[0] > errs[1] > errs[2]
    assert errs[2] < 0.003


def test_prandtl_glauert_similarity():
    # CL_alpha(AR, M) = CL_alpha_inc(beta AR) / beta ; reference-note value AR 8, M 0.6: 5.38
    beta = math.sqrt(1 - 0.6**2)
    comp = _cl_alpha(8.0, 8, 16, mach=0.6)
    inc = _cl_alpha(8.0 * beta, 8, 16)
    assert comp == pytest.approx(inc / beta, rel=0.01)
    assert comp == pytest.approx(5.38, rel=0.02)


def _theodorsen(k: float) -> dict[str, complex]:
    """2D lift (up) and moment (nose up, about mid-chord) per unit plunge (up) and pitch, rho = V = 1, b = 0.5."""
    b = 0.5
    ck = hankel2(1, k) / (hankel2(1, k) + 1j * hankel2(0, k))
    om = 2 * k  # omega = k V / b
    s = 1j * om
    return {
        "Lh": -math.pi * b**2 * s**2 - 2 * math.pi * b * ck * s,
        "La": math.pi * b**2 * s + 2 * math.pi * b * ck * (1 + b / 2 * s),
        "Mh": -math.pi * b**2 * ck * s,
        "Ma": math.pi * b**2 * (-b / 2 * s - b**2 / 8 * s**2) + math.pi * b**2 * ck * (1 + b / 2 * s),
    }


def test_harmonic_plunge_and_pitch_follow_theodorsen():
    nc, ns = 32, 16
    mesh = _rect(100.0, nc, ns)
    system = build_uvlm(mesh, 0.0, 1.0 / nc, wake_chords=30.0)
    shapes = np.column_stack([np.ones(mesh.n_nodes), -(mesh.x - 0.5)])
    ks = np.array([0.1, 0.2, 0.5, 1.0])
    forces = panel_forces_frequency(system, shapes, ks)
    root = np.arange(nc)  # the root strip is mid-span of the full (mirrored) wing
    dy = system.dy_hat[0]
    arm = system.force_xy[root, 0] - 0.5
    for n, k in enumerate(ks):
        ref = _theodorsen(k)
        got = {
            "Lh": forces[n, root, 0].sum() / dy,
            "La": forces[n, root, 1].sum() / dy,
            "Mh": -(forces[n, root, 0] * arm).sum() / dy,
            "Ma": -(forces[n, root, 1] * arm).sum() / dy,
        }
        for key, val in got.items():
            assert abs(val) / abs(ref[key]) == pytest.approx(1.0, abs=0.05), (k, key)
            assert abs(np.angle(val / ref[key])) < 0.05, (k, key)  # rad
            assert abs(val - ref[key]) / abs(ref[key]) < 0.05, (k, key)


def test_indicial_lift_follows_wagner():
    nc = 16
    mesh = _rect(100.0, nc, 16)
    system = build_uvlm(mesh, 0.0, 1.0 / nc, wake_chords=30.0)
    n_t = int(20.0 / system.dt_star) + 1
    wash = np.full((n_t, system.n_panels, 1), -1.0)  # step of 1 rad incidence: w = -V alpha
    g = march(system, wash)[:, :, 0]
    forces = system.dy_hat * ((system.diff_x @ g.T).T + system.dx_hat * bdf2(g, system.dt_star))
    lift = forces[:, :nc].sum(axis=1) / system.dy_hat[0]
    wagner = {2: 0.669, 4: 0.758, 10: 0.875, 20: 0.937, 40: 0.970}  # s = V t / b
    for s, phi in wagner.items():
        n = int(round(s / 2 / system.dt_star))
        assert lift[n] / math.pi == pytest.approx(phi, rel=0.05), s  # 2 pi rho V^2 b alpha phi = pi phi


def _wing(nc: int = 6, ns: int = 8):
    pf = Planform(root_chord=1.0, tip_chord=0.3, semispan=1.2, sweep_le=math.radians(45), n_chord=nc, n_span=ns)
    mesh = standard_mesh(pf)
    xi, eta = pf.to_xi_eta(mesh.x, mesh.y)
    shapes = np.column_stack([eta**2, eta * (xi - 0.4), np.sin(math.pi * eta) * xi])
    return mesh, shapes * 0.01


def test_time_march_matches_frequency_response_and_state_space():
    mesh, shapes = _wing()
    dt = 1.0 / mesh.n_chord
    solver = UvlmSolver(wake_chords=8.0, refine=1)
    assert isinstance(solver, UnsteadySolver)
    k = 0.4
    n_t = 1200
    t = np.arange(n_t) * dt
    ramp = np.clip(t / 10.0, 0, 1)
    sig = np.column_stack([ramp * np.sin(2 * k * t), 0.5 * ramp * np.cos(2 * k * t), np.zeros(n_t)])
    gac = solver.simulate(mesh, shapes, sig, 0.5, dt)
    h = frequency_response(mesh, shapes, 0.5, [k], dt_star=dt, wake_chords=8.0, derivative="bdf2")[0]
    u_hat = np.array([-1j, 0.5, 0.0])  # complex amplitude of the signals: u = Re(u_hat e^{i w t})
    pred = np.real(np.outer(np.exp(1j * 2 * k * t), h @ u_hat))
    tail = slice(n_t - 200, n_t)
    scale = np.abs(pred[tail]).max()
    assert np.abs(gac[tail] - pred[tail]).max() < 1e-6 * scale
    # full-order state space reproduces the march
    system = build_uvlm(mesh, 0.5, dt, wake_chords=8.0)
    ss = uvlm_state_space(system, shapes)
    out = ss.simulate(sig[:300])
    assert np.abs(out - gac[:300]).max() < 1e-9 * np.abs(gac[:300]).max()
    assert ss.is_stable()
    # and its frequency response is the z-domain one (BDF2 input derivative)
    np.testing.assert_allclose(ss.freqresp([k])[0], h, rtol=1e-8, atol=1e-10 * np.abs(h).max())
    # refined lattice + sub-steps: the march equals the z-domain response of the refined system at dt / 2
    gac2 = UvlmSolver(wake_chords=8.0, refine=2).simulate(mesh, shapes, sig, 0.5, dt)
    h2 = frequency_response(mesh, shapes, 0.5, [k], dt_star=dt / 2, wake_chords=8.0, derivative="bdf2", refine=2)[0]
    pred2 = np.real(np.outer(np.exp(1j * 2 * k * t), h2 @ u_hat))
    scale2 = np.abs(pred2[tail]).max()
    assert np.abs(gac2[tail] - pred2[tail]).max() < 3e-3 * scale2  # sub-step interpolation error (k dt)^4 scale
    assert np.abs(pred2[tail] - pred[tail]).max() > 1e-2 * scale2  # while the refinement changes the loads ~3 %


def test_substep_interpolation_is_causal_and_fourth_order():
    t = np.arange(40) * 0.2
    u = np.sin(0.7 * t)[:, None]
    fine = substep_signals(u, 4)
    tf = np.arange(fine.shape[0]) * 0.05
    np.testing.assert_allclose(fine[::4], u, atol=1e-15)  # passes through the samples
    assert np.abs(fine[12:, 0] - np.sin(0.7 * tf[12:])).max() < 2e-5  # (0.14)^4 / 24 scale, past the start
    # changing sample n + 2 leaves every value up to t_(n+1) unchanged (causal: outputs at t_(n+1) unaffected)
    v = u.copy()
    v[20] += 1.0
    np.testing.assert_array_equal(substep_signals(v, 4)[: 18 * 4 + 1], fine[: 18 * 4 + 1])


def test_refined_mesh_interpolates_the_same_shapes():
    mesh, shapes = _wing(4, 5)
    fine, interp = refine_mesh(mesh, 3)
    assert (fine.n_chord, fine.n_span) == (12, 15)
    np.testing.assert_allclose((interp @ shapes)[:: 1][fine.grid(np.arange(fine.n_nodes))[::3, ::3].ravel()],
                               shapes, atol=1e-14)  # coarse nodes are reproduced
    xi, eta = fine.planform.to_xi_eta(fine.x, fine.y)
    np.testing.assert_allclose(interp @ (mesh.x * 2.0 + mesh.y), fine.x * 2.0 + fine.y, atol=1e-12)  # bilinear exact


def test_batched_columns_equal_separate_runs_and_progress_cancels():
    mesh, shapes = _wing(4, 5)
    solver = UvlmSolver(wake_chords=5.0)
    rng = np.random.default_rng(1)
    a, b = rng.standard_normal((100, 3)), rng.standard_normal((100, 3))
    both = solver.simulate(mesh, shapes, np.stack([a, b], axis=2), 0.3, 0.25)
    sep = solver.simulate(mesh, shapes, b, 0.3, 0.25)
    np.testing.assert_allclose(both[:, :, 1], sep, rtol=1e-10, atol=1e-14)
    calls = []

    def cancel(frac, msg):
        calls.append(frac)
        if frac > 0.2:
            raise Cancelled()

    with pytest.raises(Cancelled):
        solver.simulate(mesh, shapes, a, 0.3, 0.25, progress=cancel)
    assert calls


def test_warning_above_mach_09_and_input_errors():
    solver = UvlmSolver()
    assert solver.info(0.45).warnings == []
    (phase,) = solver.info(0.87).warnings  # above M 0.5: the measured phase error against the DLM
    assert "phase" in phase and "9-15 deg at M 0.87" in phase
    assert "unreliable" in solver.info(0.95).warnings[-1]
    mesh, shapes = _wing(4, 5)
    with pytest.raises(ValueError, match="mach"):
        solver.simulate(mesh, shapes, np.zeros((10, 3)), 1.2, 0.1)
    with pytest.raises(ValueError, match="signals"):
        solver.simulate(mesh, shapes, np.zeros((10, 2)), 0.5, 0.1)
    with pytest.raises(ValueError, match="shapes"):
        solver.simulate(mesh, shapes[:-1], np.zeros((10, 3)), 0.5, 0.1)
    with pytest.raises(ValueError, match="dt_star"):
        solver.simulate(mesh, shapes, np.zeros((10, 3)), 0.5, -0.1)


def test_gac_converges_with_panel_count_on_cropped_delta_planform():
    # successive refinements of the lattice change a GAC matrix at k = 0.3 less and less (M = 0.87)
    pf0 = Planform(root_chord=0.37, tip_chord=0.075, semispan=0.26, sweep_le=math.radians(43), n_chord=5, n_span=7)
    out = []
    for r in (1, 2, 4):
        pf = Planform(pf0.root_chord, pf0.tip_chord, pf0.semispan, pf0.sweep_le, n_chord=5 * r, n_span=7 * r)
        mesh = standard_mesh(pf)
        xi, eta = pf.to_xi_eta(mesh.x, mesh.y)
        shapes = np.column_stack([eta**2, eta**2 * (mesh.x / pf.c_ref - 0.5)])
        out.append(frequency_response(mesh, shapes, 0.87, [0.3], dt_star=1.0 / pf.n_chord, wake_chords=10.0)[0])
    d1 = np.abs(out[1] - out[0]).max()
    d2 = np.abs(out[2] - out[1]).max()
    assert d2 < 0.6 * d1
    assert d2 < 0.03 * np.abs(out[2]).max()
