"""The band gate of a constant-density sweep (docs/flutter.md 9.10).

A constant-density sweep starts at V = 0, where every mode's reduced frequency k = omega b / V is far above any
ROM's band. With ``k_band``, an unstable run of a branch that lies wholly above the band and ends inside the
sweep is the ROM outside its validity and is not counted as flutter; a run that reaches into the band counts
from its onset. A constant-speed sweep keeps its k and reports a crossing above the band with ``outside_band``.

References: (1) a 2-mode model whose aerodynamics has, on top of a skew stiffness coupling that gives a genuine
coalescence flutter, a high-pass term destabilizing mode 2 only at k >> 2 (the shape of the RFA artifact of
AGARD 445.6 at M 0.678): its flutter speed is checked against the eigenvalues of its own continuous state
matrix built here, not by the search's code; (2) the typical section's crossing (Jones aerodynamics) with no band.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from romams_core.errors import InputError
from romams_core.flutter import flutter_analysis
from romams_core.flutter.analysis import band_gate
from romams_core.flutter.sweeps import make_sweep
from romams_core.statespace import ContinuousSS
from romams_core.typical_section import TypicalSection, jones_discrete, modes

BETA, EPS, DAMP, SKEW = 20.0, 0.1, 0.05, 0.5  # high-pass pole (t*), its gain, aero damping, stiffness coupling
OMEGA = np.array([10.0, 30.0])  # rad/s
RHO = 1.0
ART = ContinuousSS(A=np.array([[-BETA]]), B=np.array([[0.0, 1.0]]), C=np.array([[0.0], [EPS * BETA**2]]),
                   D=np.array([[0.0, SKEW], [-SKEW, -EPS * BETA]]), D1=np.array([[-DAMP, 0.0], [0.0, EPS - DAMP]]))
# H22(s*) = EPS s*^2 / (s* + BETA) - DAMP s*: negative damping for |s*| >> BETA (k >> 10), positive below


def _max_growth(v: float) -> float:
    """Largest Re(s) (1/s) of the structural roots of the model ``ART`` at speed v (m/s), c_ref = 1 m, from its
    own continuous state matrix [xi, xi_dot, y]: xi'' = -Omega^2 xi + q (C y + D xi + D1 xi_dot / v),
    y_dot = v (A y + B xi)."""
    q = 0.5 * RHO * v**2
    a = np.zeros((5, 5))
    a[0:2, 2:4] = np.eye(2)
    a[2:4, 0:2] = -np.diag(OMEGA**2) + q * ART.D
    a[2:4, 2:4] = q * ART.D1 / v
    a[2:4, 4:5] = q * ART.C
    a[4:5, 0:2] = v * ART.B
    a[4:5, 4:5] = v * ART.A
    lam = np.linalg.eigvals(a)
    return float(lam[np.abs(lam.imag) > 1.0].real.max())


def _art(k_band: float | None, tracking: str):
    return flutter_analysis(OMEGA, ART, 1.0, 0.3, sweep="constant-density", rho_ref=RHO, v_max=100.0,
                            k_band=k_band, tracking=tracking)


@pytest.mark.parametrize("tracking", ["auto", "eigen"])
def test_instability_above_the_band_that_ends_is_not_counted(tracking):
    # the model itself: mode 2 unstable near V = 0 (k >> 2), stable again by 2 m/s, unstable again past ~40 m/s
    assert _max_growth(0.5) > 0 and _max_growth(2.0) < 0 and _max_growth(20.0) < 0
    free = _art(None, tracking)
    assert free.flutter_found and free.v_flutter_m_s < 1e-2  # the artifact, reported at the sweep's start
    gated = _art(2.0, tracking)
    assert gated.flutter_found and not gated.outside_band and gated.k_flutter < 2.0
    v_f = gated.v_flutter_m_s
    assert _max_growth(v_f * (1 - 1e-5)) < 0 < _max_growth(v_f * (1 + 1e-5))  # the genuine crossing
    assert gated.unstable_above_band_v_m_s is not None
    assert 0.5 < gated.unstable_above_band_v_m_s < 2.0
    k_note = OMEGA[1] * 0.5 / gated.unstable_above_band_v_m_s  # the run's last reduced frequency: above the band
    assert k_note > 2.0 and "not counted as flutter" in gated.message


TS = TypicalSection()
W, _ = modes(TS)
SS = jones_discrete(TS, 0.05)
MACH = 0.3


def _density(tracking: str, k_band: float | None):
    return flutter_analysis(W, SS, TS.c_ref, MACH, sweep="constant-density", rho_ref=0.5, v_max=400.0,
                            k_band=k_band, tracking=tracking)


@pytest.mark.parametrize("tracking", ["auto", "eigen"])
def test_band_above_the_crossing_leaves_it_unchanged(tracking):
    free = _density(tracking, None)
    assert free.flutter_found and free.unstable_above_band_v_m_s is None
    gated = _density(tracking, 2.0 * free.k_flutter)
    assert gated.flutter_found and not gated.outside_band
    assert gated.v_flutter_m_s == pytest.approx(free.v_flutter_m_s, rel=1e-9)
    assert gated.flutter_mode == free.flutter_mode and gated.sdoff == free.sdoff
    assert gated.unstable_above_band_v_m_s is None and "NOTE" not in gated.message


@pytest.mark.parametrize("tracking", ["auto", "eigen"])
def test_instability_above_the_band_that_reaches_it_counts_from_its_onset(tracking):
    """The typical section's branch goes unstable at k_f and stays unstable while k falls into a band of k_f / 2:
    the crossing is the same as with no band (never a higher, unsafe speed), flagged outside the band."""
    free = _density(tracking, None)
    band = 0.5 * free.k_flutter
    gated = _density(tracking, band)
    assert gated.flutter_found and gated.outside_band and "above the band" in gated.message
    assert gated.v_flutter_m_s == pytest.approx(free.v_flutter_m_s, rel=1e-9)
    assert gated.flutter_mode == free.flutter_mode
    assert gated.unstable_above_band_v_m_s is None  # nothing was left uncounted
    i = int(np.searchsorted(gated.v, 2.0 * gated.v_flutter_m_s))  # the branch has reached the band there
    k_branch = np.abs(gated.omega[i:, gated.flutter_mode - 1]) * 0.5 * TS.c_ref / gated.v[i:]
    assert i < gated.v.size and np.all(gated.g[i:, gated.flutter_mode - 1] > 0) and np.all(k_branch <= band)


def test_constant_speed_sweep_is_not_gated():
    free = flutter_analysis(W, SS, TS.c_ref, MACH, sweep="constant-speed")
    r = flutter_analysis(W, SS, TS.c_ref, MACH, sweep="constant-speed", k_band=0.5 * free.k_flutter)
    assert r.flutter_found and r.outside_band and "WARNING" in r.message
    assert r.q_flutter_pa == pytest.approx(free.q_flutter_pa, rel=1e-12)
    assert r.unstable_above_band_v_m_s is None


def test_band_gate_applies_to_constant_density_only():
    args = (MACH, W, TS.c_ref, 0.5, 300.0, None, None, (0.0, 20_000.0))
    assert band_gate(make_sweep("constant-density", *args), 1.5) == 1.5
    assert math.isinf(band_gate(make_sweep("constant-density", *args), None))
    assert math.isinf(band_gate(make_sweep("constant-speed", *args), 1.5))
    assert math.isinf(band_gate(make_sweep("matched", *args), 1.5))


def test_bad_band_names_the_field():
    with pytest.raises(InputError) as exc:
        _density("auto", -1.0)
    assert exc.value.field == "k_band"
