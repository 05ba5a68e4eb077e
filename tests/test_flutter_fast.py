"""The fast Tustin path of the flutter search gives the reference path's results.

Fast path (romams_core.flutter, Tustin coupling with a diagonalizable aero matrix): eigenvalues without
eigenvectors, structural eigenvector parts from the null vector of the k x k matrix
T(s) = s^2 I + s G + K - q H(s) with H from the diagonalized aero matrix, and brentq on Newton roots of
det T(s). Reference path: full LAPACK eigenvectors and brentq on full eigen-solves (what the module did
before, and still does when the aero matrix is not reliably diagonalizable). Forcing the reference path
(diagonalization refused) must not change any result beyond rounding: flutter point to 1e-9, flutter mode,
SDOFF flag, V-g data.
"""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest

from romams_core.flutter import eigen, flutter_analysis, model, newton
from romams_core.statespace import ContinuousSS, to_modal
from romams_core.typical_section import TypicalSection, jones_discrete, modes

OMEGA4 = np.array([60.0, 150.0, 260.0, 420.0])


def random_rom(seed: int, na: int = 10, k: int = 4) -> SimpleNamespace:
    """A coupled, stable discrete aero model (spectral radius 0.92) with k inputs/outputs, dt* = 0.1."""
    rng = np.random.default_rng(seed)
    q1, _ = np.linalg.qr(rng.standard_normal((na, na)))
    q2, _ = np.linalg.qr(rng.standard_normal((na, na)))
    return SimpleNamespace(A=0.92 * q1 @ q2, B=0.3 * rng.standard_normal((na, k)),
                           C=0.3 * rng.standard_normal((k, na)), D=0.5 * rng.standard_normal((k, k)), dt_star=0.1)


EIGEN = "eigen"  # both paths on the same tracker: the default continues the fast path's branches by Newton, which
# the reference path (no diagonalization) does with eigen-solves (test_flutter_continuation compares the trackers)


def both_paths(monkeypatch: pytest.MonkeyPatch, fn):
    """(fast result, reference result) of fn(); the reference path is forced by refusing diagonalization."""
    model.PREP_CACHE.clear()
    fast = fn()
    with monkeypatch.context() as mp:
        mp.setattr(model, "DIAG_COND_MAX", 0.0)
        model.PREP_CACHE.clear()
        ref = fn()
    model.PREP_CACHE.clear()
    return fast, ref


def assert_same(fast, ref) -> None:
    """Same flutter point (1e-9), mode, SDOFF flag and V-g data."""
    assert fast.flutter_found == ref.flutter_found
    assert fast.flutter_mode == ref.flutter_mode
    assert fast.sdoff == ref.sdoff and fast.single_mode_unstable == ref.single_mode_unstable
    if ref.flutter_found:
        for f in ("q_flutter_pa", "v_flutter_m_s", "omega_flutter_rad_s", "energy_share"):
            assert getattr(fast, f) == pytest.approx(getattr(ref, f), rel=1e-9, abs=1e-12), f
        np.testing.assert_allclose(fast.modal_share, ref.modal_share, atol=1e-9)
    np.testing.assert_allclose(fast.g, ref.g, atol=1e-9)
    np.testing.assert_allclose(np.abs(fast.omega), np.abs(ref.omega), rtol=1e-9, atol=1e-9)


def test_defective_aero_matrix_keeps_the_reference_path():
    """The Jones model's input-delay chain makes A defective (repeated pole, Jordan block): it is not
    diagonalized (eigenvector condition above the limit), the search uses full eigenvectors, and the flutter
    speed is the one of test_flutter.py (U_F / (b w_alpha) = 2.1704 for dt* = 0.05 against the Jones k-method)."""
    ts = TypicalSection()
    w, _ = modes(ts)
    ss = jones_discrete(ts, 0.05)
    model.PREP_CACHE.clear()
    prep = model.aero_prep(np.asarray(ss.A), ss.dt_star, "tustin")
    assert prep.lam is None and prep.abar is not None
    r = flutter_analysis(w, ss, ts.c_ref, 0.0, sweep="constant-density", rho_ref=ts.rho,
                         v_max=4.0 * ts.semichord_m * ts.omega_alpha, rtol=1e-8)
    assert r.v_flutter_m_s / (ts.semichord_m * ts.omega_alpha) == pytest.approx(2.17040, rel=2e-5)


@pytest.mark.parametrize("seed", range(12))
def test_random_four_mode_models_fast_equals_reference(monkeypatch, seed):
    """12 random coupled 4-mode ROMs (coalescence and SDOFF cases) at zeta = 0.01: fast path = reference path."""
    rom = random_rom(seed)
    kw = dict(zeta=0.01, a_ref=300.0, rho_ref=1.0, tracking=EIGEN)
    fast, ref = both_paths(monkeypatch, lambda: flutter_analysis(OMEGA4, rom, 1.0, 0.8, **kw))
    assert ref.flutter_found
    assert_same(fast, ref)


def test_random_model_matched_sweep_fast_equals_reference(monkeypatch):
    """Matched sweep (altitude and speed change together) of a random 4-mode ROM: fast path = reference path."""
    rom = random_rom(4)
    fast, ref = both_paths(monkeypatch, lambda: flutter_analysis(OMEGA4, rom, 1.0, 0.8, sweep="matched", zeta=0.01,
                                                                 tracking=EIGEN))
    assert_same(fast, ref)


def _model_and_points(seed: int = 3):
    """Fast-path model of a random ROM and three (V, q) sweep points."""
    m = model.make_model(OMEGA4, np.full(4, 0.01), 1.0, random_rom(seed), "tustin")
    assert m.lam_a is not None
    v = np.array([240.0, 240.0, 150.0])
    q = np.array([2000.0, 9000.0, 30000.0])
    return m, v, q


def test_null_vectors_of_t_are_the_eigenvector_structural_parts():
    """T(s) null vectors = structural parts [xi; xi'/omega] of the full eigenvectors: MAC 1 to 1e-10 for every root."""
    m, v, q = _model_and_points()
    ef = eigen.eig_batch(m, v, q)
    lam_f, xs_f = ef.lam, ef.xs
    full = dataclasses.replace(m, lam_a=None, res=None, base=None)
    er = eigen.eig_batch(full, v, q)
    lam_r, xs_r = er.lam, er.xs
    for i in range(v.size):
        for j in range(lam_r.shape[1]):
            jf = int(np.argmin(np.abs(lam_f[i] - lam_r[i, j])))
            assert abs(lam_f[i, jf] - lam_r[i, j]) <= 1e-10 * abs(lam_r[i, j])
            mac = abs(np.vdot(xs_r[i, :, j], xs_f[i, :, jf])) ** 2
            assert mac == pytest.approx(1.0, abs=1e-10)
            assert np.linalg.norm(xs_f[i, :, jf]) == pytest.approx(1.0, abs=1e-12)


def test_newton_root_converges_to_an_eigenvalue():
    """Newton on det T(s) from a start 1 % off converges to the coupled matrix's eigenvalue (1e-10 relative)."""
    m, v, q = _model_and_points()
    lam = eigen.eig_batch(m, v, q, vectors=False).lam
    for i in range(v.size):
        osc = lam[i][(lam[i].imag > 10.0) & (np.abs(lam[i]) < 600.0)]
        for s_true in osc:
            s = newton.newton_root(m, v[i] / m.c_ref, q[i], s_true * (1.0 + 0.01j), abs(s_true))
            assert abs(s - s_true) <= 1e-10 * abs(s_true)


def test_aero_preparation_is_cached_per_matrix_and_checks_repeat():
    """Equal A matrices share one preparation; an unstable A is refused every time (failures are not cached)."""
    rom = random_rom(0)
    model.PREP_CACHE.clear()
    p1 = model.aero_prep(np.array(rom.A), 0.1, "tustin")
    assert model.aero_prep(np.array(rom.A).copy(), 0.1, "tustin") is p1
    assert model.aero_prep(np.array(rom.A), 0.05, "tustin") is not p1  # dt* is part of the key
    assert p1.radius == pytest.approx(0.92, rel=1e-12)
    bad = 1.01 * np.eye(2)
    for _ in range(2):
        with pytest.raises(ValueError, match="unstable"):
            model.aero_prep(bad, 0.1, "tustin")


def rfa_rom(seed: int, m: int = 6, lags: tuple[float, ...] = (0.2, 0.6, 1.5)) -> tuple[ContinuousSS, np.ndarray]:
    """A rational-function ROM in m basis coordinates (each lag pole repeated m times, D1, D2 terms) and a random
    projection gamma [m, 4]: as the DLM ROMs, the modal model has aero states the 4 modes neither drive nor see."""
    rng = np.random.default_rng(seed)
    a = np.kron(np.diag(-np.asarray(lags)), np.eye(m))
    b = np.kron(np.ones((len(lags), 1)), np.eye(m))
    return ContinuousSS(A=a, B=b, C=0.3 * rng.standard_normal((m, a.shape[0])), D=0.5 * rng.standard_normal((m, m)),
                        D1=0.2 * rng.standard_normal((m, m)), D2=0.01 * rng.standard_normal((m, m))), \
        rng.standard_normal((m, 4))


@pytest.mark.parametrize("seed", range(4))
def test_rfa_model_with_repeated_poles_fast_equals_reference(monkeypatch, seed):
    """The fast path couples the minimal realization (the aero states the 4 modes neither drive nor see removed)
    and takes a root exactly on an aero pole as a pure aero root (structural part 0, content 0, lag root) instead
    of sending the whole sweep to the full eigenvectors; the search equals the reference path (full model)."""
    ss, gamma = rfa_rom(seed)
    aero = to_modal(ss, gamma)
    m = model.make_model(OMEGA4, np.full(4, 0.01), 1.0, aero, "tustin")
    v, q = np.array([240.0, 240.0]), np.array([2000.0, 9000.0])
    lam = np.linalg.eigvals(eigen._tustin_matrices(m, v, q))
    assert m.lam_a is not None
    on_pole = (v / m.c_ref)[:, None] * m.lam_a[None, :1]  # what LAPACK may return for such a state, exactly
    sv = eigen.struct_vectors(m, np.concatenate([lam, on_pole], axis=1), v, q)
    assert sv is not None
    assert np.all(sv[0][:, :, -1] == 0.0) and np.all(sv[1][:, -1] == 0.0) and np.all(sv[2][:, -1])
    assert m.na == 12 and aero.A.shape[0] == 18  # minimal realization: 3 lag poles x 4 modes (not x 6 shapes)
    fast, ref = both_paths(monkeypatch, lambda: flutter_analysis(OMEGA4, aero, 1.0, 0.8, zeta=0.01, a_ref=300.0,
                                                                  rho_ref=1.0, tracking=EIGEN))
    assert ref.flutter_found
    assert_same(fast, ref)
