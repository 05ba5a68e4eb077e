"""ARX identification on synthetic systems with known coefficients."""

import numpy as np
import pytest

from romams_core.arx import ArxModel, arx_simulate, fit_arx, nrmse
from romams_core.statespace import arx_to_ss


def _random_arx(rng: np.random.Generator, na: int, nb: int, p: int, m: int) -> ArxModel:
    a = rng.standard_normal((na, p, p)) * 0.15 / np.arange(1, na + 1)[:, None, None]
    b = rng.standard_normal((nb, p, m))
    model = ArxModel(a=a, b=b, dt_star=0.1)
    assert arx_to_ss(model).is_stable()
    return model


def test_fit_recovers_known_mimo_arx_exactly():
    rng = np.random.default_rng(3)
    true = _random_arx(rng, na=4, nb=3, p=3, m=2)
    u = rng.standard_normal((600, 2))
    f = arx_simulate(true, u)
    got = fit_arx(u, f, na=4, nb=3)
    np.testing.assert_allclose(got.a, true.a, atol=1e-8)
    np.testing.assert_allclose(got.b, true.b, atol=1e-8)
    np.testing.assert_allclose(nrmse(f, arx_simulate(got, u)), 0.0, atol=1e-8)


def test_simulation_equals_state_space_realization():
    rng = np.random.default_rng(4)
    model = _random_arx(rng, na=3, nb=4, p=2, m=3)
    u = rng.standard_normal((200, 3))
    np.testing.assert_allclose(arx_to_ss(model).simulate(u), arx_simulate(model, u), rtol=1e-10, atol=1e-12)


def test_ridge_shrinks_and_nrmse_definition():
    rng = np.random.default_rng(5)
    true = _random_arx(rng, na=2, nb=2, p=2, m=2)
    u = rng.standard_normal((400, 2))
    f = arx_simulate(true, u)
    plain = fit_arx(u, f, 2, 2)
    shrunk = fit_arx(u, f, 2, 2, ridge=10.0)
    assert np.linalg.norm(shrunk.b) < np.linalg.norm(plain.b)
    ref = np.column_stack([np.ones(4), 2 * np.ones(4)])
    np.testing.assert_allclose(nrmse(ref, ref * 1.1), [0.1, 0.1], rtol=1e-12)


@pytest.mark.parametrize(
    "kwargs, field",
    [({"na": -1}, "na"), ({"nb": 0}, "nb"), ({"ridge": -1.0}, "ridge")],
)
def test_bad_input_names_the_field(kwargs, field):
    u = np.zeros((500, 2))
    with pytest.raises(ValueError, match=field):
        fit_arx(u, u, **kwargs)
    with pytest.raises(ValueError, match="u"):
        fit_arx(np.zeros((10, 2)), np.zeros((10, 2)), 4, 4)


def test_ar_ridge_shrinks_only_the_autoregressive_part():
    rng = np.random.default_rng(6)
    true = _random_arx(rng, na=3, nb=3, p=2, m=2)
    u = rng.standard_normal((800, 2))
    f = arx_simulate(true, u)
    exact = fit_arx(u, f, 3, 3, ar_ridge=1e-12)
    np.testing.assert_allclose(exact.a, true.a, atol=1e-6)  # a tiny value leaves a consistent fit unchanged
    fir = fit_arx(u, f, 3, 3, ar_ridge=1e8)
    assert np.abs(fir.a).max() < 1e-4  # a huge value forces an FIR model ...
    plain_fir = fit_arx(u, f, 0, 3)
    np.testing.assert_allclose(fir.b, plain_fir.b, rtol=1e-3, atol=1e-3 * np.abs(plain_fir.b).max())  # ... the FIR fit


def test_band_part_splits_records_at_a_reduced_frequency():
    """Tones on the record's DFT bins at k 0.5 and 12 (omega = 2 k per t*): ``band_part`` at k 3 keeps the first
    exactly, ``out_of_band_share`` is the second's RMS share, and ``band_nrmse`` sees only the in-band error."""
    from romams_core.arx import band_nrmse, band_part, out_of_band_share

    dt, n = 0.1, 1000
    t = dt * np.arange(n)
    w_lo, w_hi = 2 * np.pi * 8 / (n * dt), 2 * np.pi * 380 / (n * dt)  # bins 8 and 380: k 0.25 and 11.9
    low = np.column_stack([np.cos(w_lo * t + 0.3), 2.0 * np.sin(w_lo * t)])
    high = 0.2 * np.column_stack([np.cos(w_hi * t), np.cos(w_hi * t + 1.0)])
    np.testing.assert_allclose(band_part(low + high, dt, 3.0), low, atol=1e-12)
    share = out_of_band_share(low + high, dt, 3.0)
    expect = np.sqrt(0.02 / (np.mean(low**2, axis=0) + 0.02))
    np.testing.assert_allclose(share, expect, rtol=1e-10)
    assert np.allclose(band_nrmse(low + high, low, dt, 3.0), 0.0, atol=1e-12)  # the high tone is out of band
    np.testing.assert_allclose(band_nrmse(low + high, 1.01 * low + high, dt, 3.0), 0.01, rtol=1e-10)
    assert np.all(nrmse(low + high, low) > 0.09)  # the whole-record error counts it
