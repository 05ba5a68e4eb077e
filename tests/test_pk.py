"""p-k flutter reference (romams_core.pk) against closed-form and independent references.

1. Hodges & Pierce typical section with the exact Theodorsen function (scipy.special.hankel2): at g = 0 the
   p-k and k methods coincide, so p-k must reproduce the k-method flutter speed U_F / (b w_alpha) = 2.18391,
   w_F / w_alpha = 0.64898 (tests/test_flutter.py computes the same reference by the k-method).
2. Cropped delta baseline at M 0.87 (constant-speed sweep, ISA 10 km): p-k with the UVLM's own frequency
   response (the full-order model) against the time-domain ROM-PMS (ARX identified on the structure's own
   modes, Tustin coupling) within 1 % in q_f (measured 0.014 %), also on the matched sweep and on a design whose
   first two branches collapse into real (zero-frequency) roots.
"""

import math

import numpy as np
import pytest
from scipy.special import hankel2

from romams_core.pk import AeroTable, pk_flutter
from romams_core.pk_reference import fom_flutter, uvlm_table
from romams_core.typical_section import TypicalSection, modes

HP = TypicalSection()  # a = -0.2, x_alpha = 0.1, r_alpha^2 = 0.24, w_h/w_a = 0.4, mu = 20
U_REF = HP.semichord_m * HP.omega_alpha
UF_K_METHOD, WF_K_METHOD = 2.18391, 0.64898  # exact-Theodorsen k-method (tests/test_flutter.py, docs/flutter.md)


def theodorsen(k: np.ndarray) -> np.ndarray:
    """Exact Theodorsen function C(k) (C(0) = 1)."""
    k = np.asarray(k, dtype=float)
    out = np.ones(k.shape, dtype=complex)
    nz = k > 0
    h1, h0 = hankel2(1, k[nz]), hankel2(0, k[nz])
    out[nz] = h1 / (h1 + 1j * h0)
    return out


def section_h(k: np.ndarray, ts: TypicalSection = HP) -> np.ndarray:
    """Modal harmonic GAC H(k) [n, 2, 2] of the section (Q / q per unit mass-normalized modal amplitude).

    Theodorsen's loads for [h (down), alpha]: Q = omega^2 Abar(k) x, so Q / q = 2 k^2 Abar / (rho b^2);
    k^2 Abar is written out so that k = 0 is regular.
    """
    k = np.atleast_1d(np.asarray(k, dtype=float))
    b, a, rho = ts.semichord_m, ts.a, ts.rho
    c = theodorsen(k)
    pr = math.pi * rho
    hh = pr * b**2 * (k**2 - 2j * c * k)
    ha = -pr * b**3 * (1j * k + a * k**2) - 2 * pr * b**3 * c * (1 + 1j * (0.5 - a) * k)
    ah = -pr * b**3 * a * k**2 + 2j * pr * b**3 * (a + 0.5) * c * k
    aa = pr * b**4 * ((0.125 + a**2) * k**2 - 1j * (0.5 - a) * k) + 2 * pr * b**4 * (a + 0.5) * c * (
        1 + 1j * (0.5 - a) * k)
    h_phys = 2.0 / (rho * b**2) * np.stack([np.stack([hh, ha], -1), np.stack([ah, aa], -1)], -2)
    _, phi = modes(ts)
    return phi.T @ h_phys @ phi


def _section_pk(aero, **kw):
    w, _ = modes(HP)
    kw.setdefault("v_max", 4.0 * U_REF)
    return pk_flutter(w, aero, HP.c_ref, 0.0, sweep="constant-density", rho_ref=HP.rho, rtol=1e-8, **kw)


def test_pk_reproduces_theodorsen_k_method_flutter_speed():
    """p-k with exact Theodorsen aerodynamics: U_F / (b w_a) 2.18391 within 0.2 % (measured 1e-5)."""
    r = _section_pk(section_h)
    assert r.flutter_found and r.flutter_mode == 2
    assert r.v_flutter_m_s / U_REF == pytest.approx(UF_K_METHOD, rel=2e-3)
    assert r.omega_flutter_rad_s / HP.omega_alpha == pytest.approx(WF_K_METHOD, rel=2e-3)
    # k at flutter is consistent with omega and V on b = c_ref / 2
    assert r.k_flutter == pytest.approx(r.omega_flutter_rad_s * HP.semichord_m / r.v_flutter_m_s, rel=1e-12)
    # gamma and g of the flutter branch are negative below and positive above V_F; g = 2 gamma / sqrt(1 + gamma^2)
    j = r.flutter_mode - 1
    assert np.all(r.gamma[r.v < 0.99 * r.v_flutter_m_s, j] < 0)
    assert np.all(r.gamma[r.v > 1.01 * r.v_flutter_m_s, j] > 0)
    np.testing.assert_allclose(r.g, 2 * r.gamma / np.sqrt(1 + r.gamma**2), rtol=1e-12, atol=1e-14)


def test_pk_with_tabulated_aerodynamics_matches_the_callable():
    """A cubic table in k (step 0.05) gives the same flutter point as the exact callable to 1e-4."""
    exact = _section_pk(section_h)
    kg = np.linspace(0.0, 12.0, 241)  # the constant-density sweep starts at V = 0.1 U_REF: k up to ~10
    tab = AeroTable(k=kg, h=section_h(kg))
    mid = 0.5 * (kg[1:] + kg[:-1])
    assert np.max(np.abs(tab(mid[2:]) - section_h(mid[2:]))) < 1e-3 * np.max(np.abs(section_h(mid)))
    r = _section_pk(tab)
    assert r.v_flutter_m_s == pytest.approx(exact.v_flutter_m_s, rel=1e-4)
    assert r.omega_flutter_rad_s == pytest.approx(exact.omega_flutter_rad_s, rel=1e-4)


def test_structural_damping_raises_the_pk_flutter_speed():
    """2 % modal damping raises the section's flutter speed (damping sign convention)."""
    base = _section_pk(section_h)
    damped = _section_pk(section_h, zeta=0.02)
    assert damped.v_flutter_m_s > base.v_flutter_m_s * 1.001


def test_crossing_inside_the_first_sweep_interval_is_refined():
    """Four coarse points up to 60 U_REF put the crossing before the first point: still 2.18391 (zeta = 0)."""
    r = _section_pk(section_h, v_max=60.0 * U_REF, n_points=4)
    assert r.v_flutter_m_s / U_REF == pytest.approx(UF_K_METHOD, rel=2e-3)
    assert "start of the sweep" not in r.message


def test_table_outside_range_and_bad_input_raise_value_error():
    kg = np.linspace(0.0, 1.0, 11)
    tab = AeroTable(k=kg, h=section_h(kg))
    with pytest.raises(ValueError, match="k:"):
        tab(np.array([1.5]))
    with pytest.raises(ValueError, match="k:"):
        AeroTable(k=kg[::-1], h=section_h(kg))
    with pytest.raises(ValueError, match="h:"):
        AeroTable(k=kg, h=section_h(kg)[:-1])
    w, _ = modes(HP)
    with pytest.raises(ValueError, match="sweep"):
        pk_flutter(w, section_h, HP.c_ref, 0.5, sweep="diagonal")
    with pytest.raises(ValueError, match="omega"):
        pk_flutter(-w, section_h, HP.c_ref, 0.5)
    with pytest.raises(ValueError, match="aero"):
        pk_flutter(np.r_[w, 3 * w[1]], section_h, HP.c_ref, 0.5)
    with pytest.raises(ValueError, match="mach"):
        pk_flutter(w, section_h, HP.c_ref, 0.0, sweep="constant-speed")
    with pytest.raises(ValueError, match="zeta"):
        pk_flutter(w, section_h, HP.c_ref, 0.5, zeta=1.5)


def test_pk_no_flutter_in_range_is_a_result():
    """A sweep ending below the flutter speed reports no flutter, with all branches damped."""
    w, _ = modes(HP)
    r = pk_flutter(w, section_h, HP.c_ref, 0.0, sweep="constant-density", rho_ref=HP.rho,
                   v_max=0.8 * UF_K_METHOD * U_REF)
    assert not r.flutter_found and r.q_flutter_pa is None
    assert np.all(r.g < 0)


@pytest.fixture(scope="module")
def cropped_delta():
    """(wing, mesh) of the cropped-delta template."""
    from romams_core.mesh import standard_mesh
    from romams_core.wing import template

    wing = template("cropped-delta")
    return wing, standard_mesh(wing.planform)


def _rom_pms(mesh, modal, mach):
    from romams_core.aero.uvlm import UvlmSolver
    from romams_core.training import train_rom

    return train_rom(mesh, modal.shapes, mach, UvlmSolver())


def test_cropped_delta_full_order_pk_matches_rom_pms(cropped_delta):
    """UVLM frequency response in p-k vs time-domain ROM-PMS on the baseline at M 0.87: q_f within 1 %.

    Measured: 8593.5 Pa vs 8594.7 Pa (1.4e-4) constant-speed; matched 8593.7 vs 8594.9 Pa.
    """
    from romams_core.flutter import flutter_analysis
    from romams_core.structure.modal import modal_analysis

    wing, mesh = cropped_delta
    modal = modal_analysis(wing, None, 4, mesh)
    mach = 0.87
    table = uvlm_table(mesh, modal.shapes, mach, k_max=2.0, n_k=41)
    fom = pk_flutter(modal.omega, table, mesh.c_ref, mach, sweep="constant-speed", zeta=wing.modal_damping)
    rom = _rom_pms(mesh, modal, mach)
    pms = flutter_analysis(modal.omega, rom.ss, rom.c_ref, mach, sweep="constant-speed", zeta=wing.modal_damping)
    assert fom.flutter_found and pms.flutter_found
    assert fom.flutter_mode == pms.flutter_mode
    assert fom.q_flutter_pa == pytest.approx(pms.q_flutter_pa, rel=0.01)
    assert fom.omega_flutter_rad_s == pytest.approx(pms.omega_flutter_rad_s, rel=0.01)
    # the reported speed is the true airspeed (M a_ref here), as in flutter_analysis; EAS from q_f and rho_0
    assert fom.v_flutter_m_s == fom.v_true_m_s == pytest.approx(mach * fom.a_ref, rel=1e-12)
    assert fom.v_eas_m_s == pytest.approx(math.sqrt(2.0 * fom.q_flutter_pa / 1.225), rel=1e-6)
    assert fom.v_eas_m_s == pytest.approx(pms.v_eas_m_s, rel=0.006) and fom.altitude_ref_m == 10_000.0
    # matched sweep (altitude with V = M a(h)), automatic k range
    fom_m, tab_m = fom_flutter(mesh, modal.omega, modal.shapes, mach, sweep="matched", zeta=wing.modal_damping)
    pms_m = flutter_analysis(modal.omega, rom.ss, rom.c_ref, mach, sweep="matched", zeta=wing.modal_damping)
    assert tab_m.k[-1] > fom_m.k_flutter
    assert fom_m.q_flutter_pa == pytest.approx(pms_m.q_flutter_pa, rel=0.01)
    assert fom_m.v_true_m_s == pytest.approx(pms_m.v_true_m_s, rel=0.01)


def test_cropped_delta_design_with_zero_frequency_branches(cropped_delta):
    """Seeded design 0 at M 0.95: branches 1 and 2 collapse into real roots (the k-iteration must settle at
    k = 0) and flutter occurs at low q on branch 2; full-order p-k vs ROM-PMS within 1 % (measured 1e-5)."""
    from romams_core.basis import random_designs
    from romams_core.flutter import flutter_analysis
    from romams_core.structure.modal import modal_analysis

    wing, mesh = cropped_delta
    design = random_designs(wing, 1, seed=7)[0]
    modal = modal_analysis(wing, design, 4, mesh)
    mach = 0.95
    fom, _ = fom_flutter(mesh, modal.omega, modal.shapes, mach, zeta=wing.modal_damping)
    rom = _rom_pms(mesh, modal, mach)
    pms = flutter_analysis(modal.omega, rom.ss, rom.c_ref, mach, sweep="constant-speed", zeta=wing.modal_damping)
    assert fom.flutter_mode == pms.flutter_mode == 2
    assert fom.q_flutter_pa == pytest.approx(pms.q_flutter_pa, rel=0.01)
    assert fom.omega_flutter_rad_s == pytest.approx(pms.omega_flutter_rad_s, rel=0.01)
    # branches 1 and 2 end as real roots: gamma is infinite there, g = 2 Re(p)/|p| = -/+ 2
    assert np.all(np.isinf(fom.gamma[-1, :2]))
    np.testing.assert_allclose(np.sort(fom.g[-1, :2]), [-2.0, 2.0], atol=1e-9)
