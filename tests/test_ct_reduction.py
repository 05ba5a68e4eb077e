"""Balanced singular-perturbation reduction of continuous RFA realizations: the steady value is kept exactly,
stability is kept, and the error stays within twice the discarded Hankel singular values."""

import numpy as np
import pytest

from romams_core.ct_reduction import balanced_realization, spa_reduce
from romams_core.errors import InputError
from romams_core.rfa import RogerRfa
from romams_core.statespace import ContinuousSS


def _rfa(m: int = 4) -> ContinuousSS:
    rng = np.random.default_rng(3)
    lags = np.array([0.2, 0.7, 1.9])
    return RogerRfa(lags=lags, a0=rng.normal(size=(m, m)), a1=rng.normal(size=(m, m)), a2=rng.normal(size=(m, m)),
                    a_lag=rng.normal(size=(3, m, m)), pairs=np.array([1.0 + 2.5j]),
                    a_pair=rng.normal(size=(1, 2, m, m))).state_space()


def test_balanced_realization_is_equivalent_and_balanced():
    full = _rfa()
    bal, hsv = balanced_realization(full)
    k = np.linspace(0.0, 3.0, 13)
    np.testing.assert_allclose(bal.freqresp(k), full.freqresp(k), rtol=1e-9, atol=1e-9)
    assert np.all(np.diff(hsv) <= 0) and bal.n_states == full.n_states == 20


@pytest.mark.parametrize("order", [4, 8, 12, 16])
def test_spa_keeps_steady_value_stability_and_the_error_bound(order):
    full = _rfa()
    bal, hsv = balanced_realization(full)
    red = spa_reduce(bal, order)
    assert red.n_states == order and red.is_stable()
    np.testing.assert_allclose(red.freqresp([0.0]), full.freqresp([0.0]), rtol=1e-9, atol=1e-9)
    k = np.linspace(0.0, 5.0, 101)
    err = np.max(np.linalg.norm(red.freqresp(k) - full.freqresp(k), ord=2, axis=(1, 2)))
    assert err <= 2.0 * hsv[order:].sum() * (1 + 1e-9)
    np.testing.assert_array_equal(red.D2, full.D2)  # the polynomial terms pass through


def test_bad_order_names_the_field():
    bal, _ = balanced_realization(_rfa())
    with pytest.raises(InputError) as e:
        spa_reduce(bal, 99)
    assert e.value.field == "order"
