"""Coupling and flutter search against a pitch-plunge typical section (independent of any 3-D solver).

References computed here, independently of romams_core: the classical k-method with (a) the exact
Theodorsen function C(k) = H1(2)(k) / (H1(2)(k) + i H0(2)(k)) and (b) R.T. Jones' rational C(k).
The k-method is exact at the g = 0 crossing (harmonic motion), so (b) is the exact flutter point of
the Jones model that romams_core.typical_section discretizes: the ROM path (FOH lag states + 2nd-order
input differences, Tustin coupling) must match it to O(dt*^2) ~ 1e-4. Jones vs exact C(k) differs by
up to ~0.013 in C, which moves the flutter speed by a fraction of a percent; we allow 1 %.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
import scipy.linalg
from scipy.optimize import brentq
from scipy.special import hankel2

from romams_core.flutter import flutter_analysis, tustin_to_continuous
from romams_core.typical_section import TypicalSection, jones_discrete, modes, structural_matrices

HP = TypicalSection()  # Hodges & Pierce data: a=-0.2, x_a=0.1, r_a^2=0.24, w_h/w_a=0.4, mu=20
U_REF = HP.semichord_m * HP.omega_alpha


def c_theodorsen(k: float) -> complex:
    """Exact Theodorsen function of the semichord reduced frequency k."""
    h1, h0 = hankel2(1, k), hankel2(0, k)
    return complex(h1 / (h1 + 1j * h0))


def c_jones(k: float) -> complex:
    """R.T. Jones' approximation of C(k)."""
    return complex(1.0 - 0.165 * k / (k - 0.0455j) - 0.335 * k / (k - 0.3j))


def k_method_flutter(ts: TypicalSection, cfun) -> tuple[float, float]:
    """(U_F / (b w_alpha), w_F / w_alpha) by the k-method: K (1 + i g) x = w^2 (M + Abar(k)) x."""
    b, rho, a = ts.semichord_m, ts.rho, ts.a
    mm, kk = structural_matrices(ts)

    def branches(k: float) -> tuple[np.ndarray, np.ndarray]:
        c = cfun(k)
        pr = math.pi * rho
        ahh = pr * b**2 * (1.0 - 2j * c / k)
        aha = -pr * b**3 * (1j / k + a) - 2 * pr * b**3 * c * (1 / k**2 + 1j * (0.5 - a) / k)
        aah = -pr * b**3 * a + 2j * pr * b**3 * (a + 0.5) * c / k
        aaa = pr * b**4 * ((0.125 + a**2) - 1j * (0.5 - a) / k) + 2 * pr * b**4 * (a + 0.5) * c * (
            1 / k**2 + 1j * (0.5 - a) / k)
        abar = np.array([[ahh, aha], [aah, aaa]])
        mu = np.linalg.eigvals(np.linalg.solve(mm + abar, kk))  # mu = w^2 / (1 + i g)
        inv = 1.0 / mu
        w = np.sqrt(1.0 / inv.real)
        g = inv.imag / inv.real
        order = np.argsort(w)
        return w[order], g[order]

    ks = np.linspace(2.0, 0.05, 400)
    gs = np.array([branches(k)[1] for k in ks])
    # flutter: a branch's required damping g crosses zero from below as k decreases (U grows)
    best = None
    for j in range(2):
        idx = np.nonzero((gs[:-1, j] < 0) & (gs[1:, j] >= 0))[0]
        if idx.size:
            i = idx[0]
            kf = brentq(lambda k, j=j: branches(k)[1][j], ks[i + 1], ks[i], xtol=1e-12)
            if best is None or kf > best[0]:
                best = (kf, j)
    assert best is not None
    kf, j = best
    wf = branches(kf)[0][j]
    return wf * b / kf / (b * ts.omega_alpha), wf / ts.omega_alpha


def run(ts: TypicalSection, dt_star: float, coupling: str = "tustin", **kw):
    """Constant-density flutter search of ``ts`` with its discrete Jones model (tight brentq tolerance)."""
    kw.setdefault("rtol", 1e-8)
    w, _ = modes(ts)
    return flutter_analysis(
        w, jones_discrete(ts, dt_star), ts.c_ref, 0.0, sweep="constant-density", coupling=coupling,
        rho_ref=ts.rho, v_max=4.0 * ts.semichord_m * ts.omega_alpha, **kw,
    )


def test_k_method_reference_matches_notes():
    """Our exact-Theodorsen k-method reproduces the notes' 2.184 / 0.649 (3.5) to 0.2 %."""
    uf, wf = k_method_flutter(HP, c_theodorsen)
    assert uf == pytest.approx(2.184, rel=2e-3)
    assert wf == pytest.approx(0.649, rel=3e-3)


def test_typical_section_tustin_matches_jones_k_method():
    """ROM path (discrete Jones model, Tustin coupling, tracking, brentq) = Jones k-method to 0.05 %."""
    uf_ref, wf_ref = k_method_flutter(HP, c_jones)
    r = run(HP, 0.05)
    assert r.flutter_found and r.coupling == "tustin" and r.sweep == "constant-density"
    assert r.v_flutter_m_s / U_REF == pytest.approx(uf_ref, rel=5e-4)
    assert r.omega_flutter_rad_s / HP.omega_alpha == pytest.approx(wf_ref, rel=5e-4)
    assert r.q_flutter_pa == pytest.approx(0.5 * HP.rho * r.v_flutter_m_s**2, rel=1e-12)
    assert r.k_flutter == pytest.approx(r.omega_flutter_rad_s * HP.semichord_m / r.v_flutter_m_s, rel=1e-12)


def test_flutter_point_above_the_identified_band_is_flagged():
    """k_band: a flutter point above the ROM's identified band keeps its numbers but is flagged with a warning;
    one inside the band is not (the typical section flutters at k = 0.649 / 2.184 = 0.30)."""
    inside = run(HP, 0.05, k_band=1.5)
    outside = run(HP, 0.05, k_band=0.2)
    assert inside.flutter_found and not inside.outside_band and "WARNING" not in inside.message
    assert outside.outside_band and "above the band" in outside.message
    assert outside.q_flutter_pa == pytest.approx(inside.q_flutter_pa, rel=1e-12)
    assert outside.k_flutter == pytest.approx(0.297, abs=0.01)


def test_typical_section_against_exact_theodorsen_and_textbook():
    """Within 1 % of the exact-Theodorsen k-method (Jones fit error) and 2 % of the textbook ~2.18."""
    uf_exact, wf_exact = k_method_flutter(HP, c_theodorsen)
    r = run(HP, 0.05)
    assert r.v_flutter_m_s / U_REF == pytest.approx(uf_exact, rel=0.01)
    assert r.omega_flutter_rad_s / HP.omega_alpha == pytest.approx(wf_exact, rel=0.01)
    assert r.v_flutter_m_s / U_REF == pytest.approx(2.18, rel=0.02)
    # classical coupled flutter: the pitch-dominated mode 2 goes unstable, not single-DOF
    assert r.flutter_mode == 2
    assert not r.sdoff
    assert r.frequency_separation < 0.3


def test_zoh_converges_to_tustin_first_order():
    """ZOH flutter speed error vs Tustin halves with dt* (first order), and Tustin is dt*-converged."""
    ref = run(HP, 0.0125).v_flutter_m_s
    errs = []
    for dt in (0.1, 0.05, 0.025):
        t = run(HP, dt).v_flutter_m_s
        z = run(HP, dt, coupling="zoh")
        assert z.coupling == "zoh"
        assert t == pytest.approx(ref, rel=1e-4)
        errs.append(abs(z.v_flutter_m_s - ref) / ref)
    assert errs[0] > 2e-3  # visible first-order bias at dt* = 0.1 ...
    ratios = [errs[0] / errs[1], errs[1] / errs[2]]
    assert ratios == pytest.approx([2.0, 2.0], abs=0.25)  # ... halving with dt*


def test_tustin_conversion_frequency_response():
    """H_d(e^{i w T}) = H_c(i (2/T) tan(w T / 2)) for the converted Jones model (1e-10)."""
    ss = jones_discrete(HP, 0.05)
    ab, bb, cb, db = tustin_to_continuous(ss.A, ss.B, ss.C, ss.D, ss.dt_star)
    n = ss.A.shape[0]
    for wt in (0.01, 0.3, 1.2):
        z = np.exp(1j * wt * ss.dt_star)
        hd = ss.C @ np.linalg.solve(z * np.eye(n) - ss.A, ss.B) + ss.D
        s = 1j * (2.0 / ss.dt_star) * math.tan(wt * ss.dt_star / 2.0)
        hc = cb @ np.linalg.solve(s * np.eye(n) - ab, bb) + db
        np.testing.assert_allclose(hc, hd, rtol=1e-10, atol=1e-10 * np.abs(hd).max())


def test_no_flutter_below_vmax_is_a_result():
    """Sweep ending below the flutter speed: flutter_found False, None values, a message, full V-g data."""
    w, _ = modes(HP)
    r = flutter_analysis(w, jones_discrete(HP, 0.05), HP.c_ref, 0.0, sweep="constant-density",
                         rho_ref=HP.rho, v_max=1.5 * U_REF, n_points=20)
    assert not r.flutter_found
    assert r.v_flutter_m_s is None and r.q_flutter_pa is None and r.flutter_mode is None
    assert "no flutter" in r.message
    assert r.g.shape == (20, 2) and r.omega.shape == (20, 2) and r.v.shape == (20,)
    assert np.all(r.g < 0)
    np.testing.assert_allclose(r.zeta, -0.5 * r.g)


def test_structural_damping_raises_flutter_speed():
    """Modal damping zeta = 0.02 delays flutter; crossing is then coupled zeta = 0."""
    r0 = run(HP, 0.05)
    r1 = run(HP, 0.05, zeta=0.02)
    assert r1.flutter_found and r1.v_flutter_m_s > r0.v_flutter_m_s * 1.005


def _one_mode_model(damping_sign: float):
    """1 mode, 1 aero lag state in t*: f = c x + d xi, x' = -0.5 x + xi (discretized by ZOH in t*).

    At low reduced frequency x ~ 2 xi - 4 xi' (t*), so f ~ (2c + d) xi - 4 c xi': c > 0 damps, c < 0
    feeds energy in; d keeps the quasi-steady stiffness 2c + d = -0.5 (stiffening, no divergence).
    """
    dt = 0.05
    a = np.array([[math.exp(-0.5 * dt)]])
    b = np.array([[(1 - math.exp(-0.5 * dt)) / 0.5]])
    c = np.array([[damping_sign * 0.5]])
    d = np.array([[-0.5 - 2.0 * c[0, 0]]])
    return SimpleNamespace(A=a, B=b, C=c, D=d, dt_star=dt)


def test_sdoff_single_mode_flutter():
    """One mode with negative aero damping: flutter found, share 1, SDOFF True; positive damping: none."""
    omega = np.array([30.0])
    kw = dict(sweep="constant-speed", q_max=20000.0, zeta=0.02)
    r = flutter_analysis(omega, _one_mode_model(-1.0), 1.0, 0.5, **kw)
    assert r.flutter_found and r.sdoff and r.single_mode_unstable and r.energy_share == pytest.approx(1.0)
    assert r.flutter_mode == 1 and r.omega_flutter_rad_s > 20.0
    assert r.frequency_separation == math.inf
    r2 = flutter_analysis(omega, _one_mode_model(+1.0), 1.0, 0.5, **kw)
    assert not r2.flutter_found


def test_sdoff_in_multimode_structure():
    """Mode 2 of 2 uncoupled modes has negative aero damping: SDOFF flagged on branch 2, share ~1."""
    m1 = _one_mode_model(+1.0)
    m2 = _one_mode_model(-1.0)
    aero = SimpleNamespace(
        A=np.diag([m1.A[0, 0], m2.A[0, 0]]), B=np.diag([m1.B[0, 0], m2.B[0, 0]]),
        C=np.diag([m1.C[0, 0], m2.C[0, 0]]), D=np.diag([m1.D[0, 0], m2.D[0, 0]]), dt_star=0.05)
    r = flutter_analysis(np.array([30.0, 80.0]), aero, 1.0, 0.5, sweep="constant-speed", q_max=40000.0, zeta=0.02)
    assert r.flutter_found and r.flutter_mode == 2 and r.sdoff
    assert r.energy_share > 0.999
    assert r.modal_share.shape == (2,)


def test_aero_lag_root_never_reported():
    """An aerodynamic oscillator root driven unstable by the coupling is not flutter (structural branch stable)."""
    # aero: lightly damped 2-state oscillator in t* (0.4 V/c ~ 60 rad/s at V = 150 m/s), one 20 rad/s mode
    dt = 0.05
    wa, za = 0.4, 0.01
    ac = np.array([[0.0, 1.0], [-wa**2, -2 * za * wa]])
    e = scipy.linalg.expm(np.block([[ac, np.array([[0.0], [1.0]])], [np.zeros((1, 3))]]) * dt)
    aero = SimpleNamespace(A=e[:2, :2], B=e[:2, 2:], C=np.array([[0.0, -1e-3]]), D=np.zeros((1, 1)), dt_star=dt)
    omega, zeta, q_max = np.array([20.0]), np.array([0.1]), 1e5
    r = flutter_analysis(omega, aero, 1.0, 0.5, sweep="constant-speed", zeta=zeta, q_max=q_max, n_points=40,
                         a_ref=300.0)
    # independent check: at q_max the coupled system has an unstable root near 60 rad/s (aero) while the
    # root near the structural frequency is damped
    ab, bb, cb, db = tustin_to_continuous(aero.A, aero.B, aero.C, aero.D, dt)
    v0 = 0.5 * 300.0
    big = np.block([
        [np.zeros((1, 1)), np.eye(1), np.zeros((1, 2))],
        [-omega[None] ** 2 + q_max * db, -2 * zeta[None] * omega[None], q_max * cb],
        [v0 * bb, np.zeros((2, 1)), v0 * ab],
    ])
    ev = np.linalg.eigvals(big)
    ev = ev[ev.imag > 0]
    unstable = ev[ev.real > 0]
    assert unstable.size == 1 and 50.0 < unstable[0].imag < 70.0
    assert not r.flutter_found
    assert np.all(r.g[:, 0] < 0)
    assert 10.0 < r.omega[-1, 0] < 25.0  # the tracked branch is the structural one


def test_bad_input_raises_value_error():
    w, _ = modes(HP)
    ss = jones_discrete(HP, 0.05)
    with pytest.raises(ValueError, match="sweep"):
        flutter_analysis(w, ss, 1.0, 0.8, sweep="bogus")
    with pytest.raises(ValueError, match="coupling"):
        flutter_analysis(w, ss, 1.0, 0.8, coupling="euler")
    with pytest.raises(ValueError, match="aero.B"):
        flutter_analysis(np.array([10.0, 20.0, 30.0]), ss, 1.0, 0.8)
    with pytest.raises(ValueError, match="omega"):
        flutter_analysis(np.array([-1.0, 2.0]), ss, 1.0, 0.8)
    with pytest.raises(ValueError, match="mach"):
        flutter_analysis(w, ss, 1.0, 0.0, sweep="constant-speed")
    unstable = SimpleNamespace(A=np.array([[1.01]]), B=np.ones((1, 1)), C=np.ones((1, 1)), D=np.zeros((1, 1)),
                               dt_star=0.1)
    with pytest.raises(ValueError, match="unstable"):
        flutter_analysis(np.array([10.0]), unstable, 1.0, 0.8)
