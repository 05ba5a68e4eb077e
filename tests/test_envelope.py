"""Safe envelope (75.6 % rule, ISA altitudes) and the per-structure evaluation pipeline."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from romams_core.atmosphere import flight_dynamic_pressure
from romams_core.envelope import compare_envelopes, envelope_from_results, safe_envelope
from romams_core.evaluate import evaluate_structure
from romams_core.flutter import flutter_analysis
from romams_core.statespace import DiscreteSS
from romams_core.typical_section import TypicalSection, jones_discrete, modes

R0 = 6356766.0  # ISA earth radius for geopotential altitude (m)


def isa_altitude_from_pressure(p: float) -> float:
    """Hand ISA inversion (troposphere and lower stratosphere), geometric altitude in m."""
    if p >= 22632.06:
        hgp = 288.15 / 0.0065 * (1.0 - (p / 101325.0) ** (1.0 / 5.255877))
    else:
        hgp = 11000.0 - math.log(p / 22632.06) / (0.0341632 / 216.65)
    return R0 * hgp / (R0 - hgp)


def test_756_percent_rule_and_cropped_delta_altitude():
    """q_safe = q_f / 1.15^2 = 75.6 % of q_f; M 0.87 experiment (2.400 psi) -> safe altitude by hand ISA."""
    qf = 2.400 * 6895.0
    env = safe_envelope([0.87], [qf])
    assert env.q_safe_pa[0] / qf == pytest.approx(0.756, abs=5e-4)
    p = env.q_safe_pa[0] / (0.7 * 0.87**2)
    assert env.safe_altitude_m[0] == pytest.approx(isa_altitude_from_pressure(p), abs=2.0)
    assert 10_500 < env.safe_altitude_m[0] < 11_000 and env.status == ["ok"]
    # stratosphere case and the value of q there equals q_safe
    env2 = safe_envelope([0.95], [9000.0])
    p2 = env2.q_safe_pa[0] / (0.7 * 0.95**2)
    assert env2.safe_altitude_m[0] == pytest.approx(isa_altitude_from_pressure(p2), abs=3.0)
    assert flight_dynamic_pressure(0.95, env2.safe_altitude_m[0]) == pytest.approx(env2.q_safe_pa[0], rel=1e-6)


def test_envelope_limits_and_no_flutter():
    env = safe_envelope([0.8, 0.8, 0.8], [None, 1e6, 100.0], altitude_range_m=(0.0, 20000.0))
    assert env.status == ["safe-everywhere", "safe-everywhere", "unsafe-in-range"]
    np.testing.assert_allclose(env.safe_altitude_m, [0.0, 0.0, 20000.0])
    assert math.isinf(env.q_flutter_pa[0])
    with pytest.raises(ValueError, match="q_flutter_pa"):
        safe_envelope([0.8, 0.9], [1000.0])
    with pytest.raises(ValueError, match="margin"):
        safe_envelope([0.8], [1000.0], margin=0.9)


def test_compare_envelopes():
    bench = safe_envelope([0.79, 0.87, 0.95], [16000.0, 15000.0, 14000.0])
    better = safe_envelope([0.79, 0.87, 0.95], [17000.0, 15000.0, None])
    worse = safe_envelope([0.79, 0.87, 0.95], [17000.0, 14000.0, 14000.0])
    cb = compare_envelopes(better, bench)
    assert cb.envelope_ok and cb.ok == [True, True, True]
    assert cb.margin_m[0] > 0 and cb.margin_m[1] == pytest.approx(0.0, abs=1e-6)
    assert cb.margin_q_pct[0] == pytest.approx((17000 / 16000 - 1) * 100, rel=1e-9)
    cw = compare_envelopes(worse, bench)
    assert not cw.envelope_ok and cw.ok == [True, False, True]
    assert cw.margin_m[1] < -100.0
    with pytest.raises(ValueError, match="benchmark"):
        compare_envelopes(safe_envelope([0.8], [1e4]), bench)


def _typical_structure(ts: TypicalSection, basis: np.ndarray):
    """Typical section as a 'structure' on a 2-node 'mesh' (h, alpha) and its Jones ROM in basis coordinates."""
    w, phi = modes(ts)
    modal = SimpleNamespace(omega=w, shapes=phi, mass_kg=ts.mass)
    phys = jones_discrete(ts, 0.05, modal=False)
    rom_ss = DiscreteSS(A=phys.A, B=phys.B @ basis, C=basis.T @ phys.C, D=basis.T @ phys.D @ basis, dt_star=0.05)
    return modal, SimpleNamespace(ss=rom_ss, c_ref=ts.c_ref)


def test_evaluate_structure_matches_direct_flutter():
    """Rotated orthonormal basis: projection + to_modal + flutter reproduce the direct modal analysis exactly."""
    ts = TypicalSection()
    th = 0.3
    basis = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
    modal, rom = _typical_structure(ts, basis)
    ev = evaluate_structure(modal, basis, {0.3: rom, 0.2: rom})
    np.testing.assert_allclose(ev.mac, 1.0, atol=1e-12)
    assert ev.mac_ok and not ev.sdoff and ev.constraints_ok and ev.comparison is None
    np.testing.assert_allclose(ev.machs, [0.2, 0.3])
    np.testing.assert_allclose(ev.frequencies_hz, modal.omega / (2 * math.pi))
    direct = flutter_analysis(modal.omega, jones_discrete(ts, 0.05), ts.c_ref, 0.3)
    assert ev.flutter[1].q_flutter_pa == pytest.approx(direct.q_flutter_pa, rel=1e-8)
    assert ev.flutter[1].sweep == "constant-speed" and ev.flutter[1].coupling == "tustin"
    env = envelope_from_results(ev.flutter)
    np.testing.assert_allclose(env.safe_altitude_m, ev.envelope.safe_altitude_m)


def test_evaluate_with_benchmark_envelope():
    """Stiffer torsion: higher q_f, lower safe altitude -> ok; softer -> envelope violated."""
    basis = np.eye(2)
    machs = (0.2, 0.3)
    base_modal, base_rom = _typical_structure(TypicalSection(), basis)
    bench = evaluate_structure(base_modal, basis, dict.fromkeys(machs, base_rom)).envelope
    stiff_modal, rom = _typical_structure(TypicalSection(omega_alpha=60.0), basis)
    ev = evaluate_structure(stiff_modal, basis, dict.fromkeys(machs, rom), benchmark=bench)
    assert ev.comparison.envelope_ok and ev.constraints_ok
    assert np.all(ev.comparison.margin_m > 0) and np.all(ev.comparison.margin_q_pct > 0)
    soft_modal, rom = _typical_structure(TypicalSection(omega_alpha=45.0), basis)
    ev2 = evaluate_structure(soft_modal, basis, dict.fromkeys(machs, rom), benchmark=bench)
    assert not ev2.comparison.envelope_ok and not ev2.constraints_ok
    assert "envelope above the benchmark" in ev2.message


def test_evaluate_flags_poor_mode_fit():
    ts = TypicalSection()
    w, phi = modes(ts)
    basis = np.array([[1.0], [0.0]])  # plunge only: pitch-dominated mode 2 fits badly
    modal = SimpleNamespace(omega=w, shapes=phi, mass_kg=ts.mass)
    phys = jones_discrete(ts, 0.05, modal=False)
    rom_ss = DiscreteSS(A=phys.A, B=phys.B @ basis, C=basis.T @ phys.C, D=basis.T @ phys.D @ basis, dt_star=0.05)
    ev = evaluate_structure(modal, basis, {0.3: SimpleNamespace(ss=rom_ss, c_ref=ts.c_ref)})
    assert not ev.mac_ok and not ev.constraints_ok and ev.min_mac < 0.98
    assert "MAC" in ev.message


def test_evaluation_serializes_round_trip():
    """StructureEvaluation (nested FlutterResult / Envelope, None, inf) survives the project's NPZ+JSON serializer."""
    from romams.serialize import dumps, loads

    basis = np.eye(2)
    modal, rom = _typical_structure(TypicalSection(), basis)
    ev = evaluate_structure(modal, basis, {0.2: rom, 0.3: rom})
    back = loads(*dumps(ev))
    assert back.flutter[1].q_flutter_pa == ev.flutter[1].q_flutter_pa
    np.testing.assert_array_equal(back.flutter[0].g, ev.flutter[0].g)
    np.testing.assert_array_equal(back.envelope.safe_altitude_m, ev.envelope.safe_altitude_m)
    assert back.comparison is None and back.envelope.status == ev.envelope.status
