"""State-space tools: balanced truncation, modal transformation, Tustin conversion."""

import numpy as np
import pytest

from romams_core.arx import ArxModel
from romams_core.statespace import (
    DiscreteSS,
    arx_to_ss,
    balanced_truncation,
    d2c_tustin,
    refit_output_map,
    reflect_unstable_poles,
    to_modal,
)


def _system(seed: int = 0, n: int = 12, m: int = 3) -> DiscreteSS:
    rng = np.random.default_rng(seed)
    poles = 0.95 * np.exp(1j * rng.uniform(0.05, 1.0, n // 2)) * rng.uniform(0.5, 1.0, n // 2)
    blocks = [np.array([[p.real, -p.imag], [p.imag, p.real]]) for p in poles]
    a = np.zeros((n, n))
    for i, blk in enumerate(blocks):
        a[2 * i : 2 * i + 2, 2 * i : 2 * i + 2] = blk
    t = rng.standard_normal((n, n))
    a = t @ a @ np.linalg.inv(t)
    return DiscreteSS(A=a, B=rng.standard_normal((n, m)), C=rng.standard_normal((m, n)), D=rng.standard_normal((m, m)),
                      dt_star=0.1)


def test_balanced_truncation_keeps_frequency_response_within_hsv_bound():
    ss = _system()
    ks = np.linspace(0.0, 1.5, 31)
    full = ss.freqresp(ks)
    red, hsv = balanced_truncation(ss, order=8)
    assert red.n_states == 8 and red.is_stable()
    err = np.abs(red.freqresp(ks) - full).max()
    assert err <= 2 * hsv[8:].sum() * (1 + 1e-6)
    exact, _ = balanced_truncation(ss)  # default tolerance keeps all 12 states: same response
    np.testing.assert_allclose(exact.freqresp(ks), full, rtol=1e-7, atol=1e-9)


def test_balanced_truncation_of_nonminimal_arx_realization():
    # ARX of a first-order SISO system realized with na = nb = 4 (7 states, 6 superfluous)
    a = np.zeros((4, 1, 1))
    a[0] = 0.8
    b = np.zeros((4, 1, 1))
    b[0] = 1.0
    b[1] = 0.5
    ss = arx_to_ss(ArxModel(a=a, b=b, dt_star=0.1))
    red, hsv = balanced_truncation(ss, hsv_tol=1e-8)
    assert red.n_states == 1
    ks = np.array([0.0, 0.3, 1.0])
    np.testing.assert_allclose(red.freqresp(ks), ss.freqresp(ks), rtol=1e-8)
    assert red.A[0, 0] == pytest.approx(0.8, rel=1e-8)


def test_to_modal_equals_projecting_the_basis_simulation():
    ss = _system(1, n=10, m=4)
    rng = np.random.default_rng(2)
    gamma = rng.standard_normal((4, 2))
    xi = rng.standard_normal((150, 2))
    direct = ss.simulate(xi @ gamma.T) @ gamma
    np.testing.assert_allclose(to_modal(ss, gamma).simulate(xi), direct, rtol=1e-10, atol=1e-10)
    with pytest.raises(ValueError, match="gamma"):
        to_modal(ss, np.ones((3, 2)))


def test_tustin_maps_frequency_response_with_warping():
    ss = _system(3)
    ct = d2c_tustin(ss)
    dt = ss.dt_star
    for k in (0.0, 0.2, 1.0):
        k_warp = np.tan(k * dt) / dt  # continuous s* = i 2 k_c with 2 k_c = (2/dt) tan(2 k dt / 2)
        np.testing.assert_allclose(ct.freqresp([k_warp])[0], ss.freqresp([k])[0], rtol=1e-9, atol=1e-9)
    # stable discrete poles map to the open left half plane
    assert np.all(np.linalg.eigvals(ct.A).real < 0)


def test_reflect_unstable_poles_and_refit_output_map():
    ss = _system(4, n=8, m=2)
    a = ss.A.copy()
    a[:2, :2] = [[1.05, -0.3], [0.3, 1.05]]  # unstable pair |z| = 1.092 on top of a stable block structure
    a[:2, 2:] = 0.0
    a[2:, :2] = 0.0
    a[4, 4] = -1.2 if abs(a[4, 4]) < 1.2 else a[4, 4]
    uns = DiscreteSS(A=a, B=ss.B, C=ss.C, D=ss.D, dt_star=0.1)
    before = np.linalg.eigvals(a)
    fixed, count = reflect_unstable_poles(uns)
    after = np.linalg.eigvals(fixed.A)
    expect = np.where(np.abs(before) >= 1, 1 / np.conj(before), before)
    assert count == int(np.sum(np.abs(before) >= 1)) >= 3
    np.testing.assert_allclose(np.sort_complex(after), np.sort_complex(expect), atol=1e-9)
    assert fixed.is_stable()
    # with A, B fixed the output map is linear: a refit on noise-free data recovers C and D
    rng = np.random.default_rng(8)
    u = rng.standard_normal((300, 2))
    y = fixed.simulate(u)
    scrambled = DiscreteSS(A=fixed.A, B=fixed.B, C=np.zeros_like(fixed.C), D=np.zeros_like(fixed.D), dt_star=0.1)
    refit = refit_output_map(scrambled, u, y)
    np.testing.assert_allclose(refit.C, fixed.C, atol=1e-8)
    np.testing.assert_allclose(refit.D, fixed.D, atol=1e-8)
