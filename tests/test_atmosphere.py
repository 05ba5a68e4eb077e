"""ISA wrapper: tabulated ISA values and the q(h) inversion used by the envelope."""

from __future__ import annotations

import numpy as np
import pytest

from romams_core.atmosphere import (
    altitude_for_dynamic_pressure,
    altitude_for_pressure,
    flight_dynamic_pressure,
    isa,
    isa_table,
)


def test_isa_tabulated_values():
    # ISA: sea level 1.225 kg/m^3, 340.294 m/s, 288.15 K, 101325 Pa; 10 km: 0.41351, 299.53 m/s, 223.25 K, 26500 Pa
    st = isa(np.array([0.0, 10000.0]))
    np.testing.assert_allclose(st.rho, [1.225, 0.41351], rtol=1e-4)
    np.testing.assert_allclose(st.a, [340.294, 299.532], rtol=1e-5)
    np.testing.assert_allclose(st.temperature, [288.15, 223.252], rtol=1e-5)
    np.testing.assert_allclose(st.pressure, [101325.0, 26499.9], rtol=1e-5)


def test_dynamic_pressure_and_inverse():
    q = flight_dynamic_pressure(0.87, 10000.0)
    # q = 0.5 gamma p M^2 with p(10 km) = 26499.87 Pa
    assert q == pytest.approx(0.7 * 26499.87 * 0.87**2, rel=1e-6)
    for h in (0.0, 3000.0, 11000.0, 17500.0, 30000.0):
        assert altitude_for_dynamic_pressure(flight_dynamic_pressure(0.91, h), 0.91) == pytest.approx(h, abs=1e-3)


def test_range_errors_and_clamp():
    with pytest.raises(ValueError, match="altitude_m"):
        isa(90000.0)
    with pytest.raises(ValueError, match="q_pa"):
        altitude_for_dynamic_pressure(1e7, 0.8)
    assert altitude_for_dynamic_pressure(1e7, 0.8, clamp=True) == pytest.approx(-5004.0)
    assert altitude_for_dynamic_pressure(1e-3, 0.8, clamp=True) == pytest.approx(81020.0)
    with pytest.raises(ValueError, match="mach"):
        altitude_for_dynamic_pressure(1000.0, 0.0)


def test_table_matches_ambiance():
    """The 10 m table is within 1e-7 of ambiance; 5e-6 right at layer boundaries (ambiance's own jump there)."""
    rng = np.random.default_rng(3)
    h = rng.uniform(-5000.0, 81000.0, 400)
    st = isa(h)
    rho, a, p = isa_table(h)
    np.testing.assert_allclose(rho, st.rho, rtol=1e-7)
    np.testing.assert_allclose(a, st.a, rtol=1e-7)
    np.testing.assert_allclose(p, st.pressure, rtol=1e-7)
    np.testing.assert_allclose(altitude_for_pressure(st.pressure), h, atol=2e-3)
    hk = np.array([11019.0, 11020.0, 20063.1, 32161.9, 47350.1])
    stk = isa(hk)
    np.testing.assert_allclose(isa_table(hk)[0], stk.rho, rtol=5e-6)
