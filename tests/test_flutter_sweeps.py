"""Consistency of the three sweep parametrizations (constant-density, constant-speed, matched).

The flutter boundary is a curve in the (V, rho) plane, so the three sweeps must land on the same point
when their reference states are chosen through it: the matched flutter altitude h_f gives q_f; a
constant-speed sweep at V = M a(h_f) must find the same q_f and rho_f = rho(h_f); a constant-density
sweep at rho_f must find V_f = M a(h_f). Tolerance 1e-4 (the brentq refinement is 1e-5 relative).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from romams_core.atmosphere import RHO_SEA_LEVEL, isa
from romams_core.flutter import flutter_analysis
from romams_core.typical_section import TypicalSection, jones_discrete, modes

TS = TypicalSection()
W, _ = modes(TS)
SS = jones_discrete(TS, 0.05)


@pytest.mark.parametrize("mach", [0.2, 0.3])
def test_matched_constant_speed_constant_density_agree(mach):
    rm = flutter_analysis(W, SS, TS.c_ref, mach, sweep="matched", altitude_range_m=(0.0, 25000.0), rtol=1e-7)
    assert rm.flutter_found and rm.sweep == "matched"
    st = isa(rm.altitude_m)
    # (the sweep uses the 10 m ISA table: 1e-7 of ambiance)
    assert rm.v_true_m_s == pytest.approx(mach * float(st.a), rel=1e-7)
    assert rm.rho_flutter == pytest.approx(float(st.rho), rel=1e-7)
    assert rm.q_flutter_pa == pytest.approx(0.5 * float(st.rho) * (mach * float(st.a)) ** 2, rel=1e-7)
    rc = flutter_analysis(W, SS, TS.c_ref, mach, sweep="constant-speed", altitude_ref_m=rm.altitude_m, rtol=1e-7)
    assert rc.q_flutter_pa == pytest.approx(rm.q_flutter_pa, rel=1e-4)
    assert rc.rho_flutter == pytest.approx(rm.rho_flutter, rel=1e-4)
    # v_flutter_m_s is the true airspeed for every sweep (M a_ref at constant speed); v_eas_m_s the EAS
    assert rc.v_flutter_m_s == pytest.approx(mach * rc.a_ref, rel=1e-12) and rc.v_true_m_s == rc.v_flutter_m_s
    assert rc.v_eas_m_s == pytest.approx(math.sqrt(2 * rc.q_flutter_pa / RHO_SEA_LEVEL), rel=1e-12)
    assert rm.v_eas_m_s == pytest.approx(math.sqrt(2 * rm.q_flutter_pa / 1.225), rel=1e-6)
    assert rc.altitude_ref_m == pytest.approx(rm.altitude_m) and rm.altitude_ref_m == 10_000.0
    rd = flutter_analysis(W, SS, TS.c_ref, mach, sweep="constant-density", rho_ref=rc.rho_flutter,
                          v_max=2.0 * rc.v_true_m_s, rtol=1e-7)
    assert rd.v_flutter_m_s == pytest.approx(rm.v_true_m_s, rel=1e-4)
    assert rd.altitude_ref_m == 10_000.0  # rho_ref given, a_ref still taken from ISA at altitude_ref_m
    re = flutter_analysis(W, SS, TS.c_ref, mach, sweep="constant-density", rho_ref=rc.rho_flutter, a_ref=rc.a_ref,
                          v_max=2.0 * rc.v_true_m_s)
    assert re.altitude_ref_m is None  # both given explicitly: no reference altitude
    assert rd.omega_flutter_rad_s == pytest.approx(rm.omega_flutter_rad_s, rel=1e-4)


def test_sweep_arrays_and_labels():
    rc = flutter_analysis(W, SS, TS.c_ref, 0.3, sweep="constant-speed", n_points=16)
    assert rc.v.shape == (16,) and rc.g.shape == (16, 2) and rc.q.shape == (16,)
    v0 = 0.3 * rc.a_ref
    np.testing.assert_allclose(rc.rho, 2 * rc.q / v0**2)
    np.testing.assert_allclose(rc.v, np.sqrt(2 * rc.q / rc.rho_ref))  # the V-g axis: sqrt(2 q / rho_ref)
    np.testing.assert_allclose(rc.v_eas, np.sqrt(2 * rc.q / RHO_SEA_LEVEL))
    assert np.all(np.isnan(rc.altitude))
    # default reference: ISA 10 km
    assert rc.rho_ref == pytest.approx(0.41351, rel=1e-4) and rc.a_ref == pytest.approx(299.53, rel=1e-4)
    rm = flutter_analysis(W, SS, TS.c_ref, 0.3, sweep="matched", n_points=16, altitude_range_m=(0.0, 20000.0))
    assert rm.v.shape == (16,)
    np.testing.assert_allclose(rm.altitude, np.linspace(20000.0, 0.0, 16))
    st = isa(rm.altitude)
    np.testing.assert_allclose(rm.v, 0.3 * st.a, rtol=1e-7)
    np.testing.assert_allclose(rm.q, 0.5 * st.rho * (0.3 * st.a) ** 2, rtol=1e-7)


def test_matched_no_flutter_in_altitude_range():
    r = flutter_analysis(W, SS, TS.c_ref, 0.2, sweep="matched", altitude_range_m=(8000.0, 20000.0))
    assert not r.flutter_found and "no flutter" in r.message and r.altitude_m is None
