"""Batched flutter across designs equals the one-at-a-time path.

``flutter_batch`` / ``evaluate_structures`` run the searches of many designs at one Mach together (one stacked
eigen-solve per sweep step, batched Newton roots, brentq per design on the shared rounds). The results must be
the single path's: flutter point within 1e-9 relative, flutter mode, SDOFF flag, V-g data and the envelope. The
designs: 30 random structures (frequencies and their projection on a 5-shape basis) x 5 Machs, each Mach with its
own random coupled aero ROM in basis coordinates (as the ROM-AMS ROMs: A shared by every design, B, C, D by the
projection), so no aerodynamic training is needed.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from romams_core.evaluate import evaluate_structure, evaluate_structures
from romams_core.flutter import batch as batch_mod
from romams_core.flutter import flutter_analysis, flutter_batch
from romams_core.flutter.crossing import brentq
from romams_core.statespace import DiscreteSS, to_modal

MACHS = (0.79, 0.83, 0.87, 0.91, 0.95)
N_DESIGNS = 30
M_BASIS = 5
FLUTTER_OPTIONS = {"a_ref": 300.0, "rho_ref": 1.0}
FIELDS = ("q_flutter_pa", "v_flutter_m_s", "v_eas_m_s", "omega_flutter_rad_s", "k_flutter", "energy_share",
          "rho_flutter")


def basis_rom(seed: int, na: int = 10, m: int = M_BASIS) -> tuple[DiscreteSS, float]:
    """A coupled, stable discrete aero ROM in basis coordinates (spectral radius 0.92, dt* = 0.1) and c_ref = 1 m."""
    rng = np.random.default_rng(seed)
    q1, _ = np.linalg.qr(rng.standard_normal((na, na)))
    q2, _ = np.linalg.qr(rng.standard_normal((na, na)))
    return DiscreteSS(A=0.92 * q1 @ q2, B=0.3 * rng.standard_normal((na, m)), C=0.3 * rng.standard_normal((m, na)),
                      D=0.5 * rng.standard_normal((m, m)), dt_star=0.1), 1.0


@pytest.fixture(scope="module")
def designs() -> tuple[np.ndarray, list[SimpleNamespace], dict[float, tuple[DiscreteSS, float]]]:
    """(basis shapes [N, m], 30 modal results with 4 modes, ROMs per Mach)."""
    rng = np.random.default_rng(5)
    basis, _ = np.linalg.qr(rng.standard_normal((60, M_BASIS)))
    modals = []
    for _ in range(N_DESIGNS):
        omega = np.sort(np.array([60.0, 150.0, 260.0, 420.0]) * rng.uniform(0.85, 1.15, 4))
        gamma = np.eye(M_BASIS)[:, :4] + 0.2 * rng.standard_normal((M_BASIS, 4))
        modals.append(SimpleNamespace(omega=omega, shapes=basis @ gamma, mass_kg=float(rng.uniform(1.0, 2.0))))
    return basis, modals, {m: basis_rom(100 + j) for j, m in enumerate(MACHS)}


def assert_same_result(b, s) -> None:
    """Batched result b equals single result s: flutter point (1e-9), mode, SDOFF, V-g data, message."""
    assert (b.flutter_found, b.flutter_mode, b.sdoff, b.single_mode_unstable) == \
        (s.flutter_found, s.flutter_mode, s.sdoff, s.single_mode_unstable)
    for f in FIELDS:
        if getattr(s, f) is None:
            assert getattr(b, f) is None, f
        else:
            assert getattr(b, f) == pytest.approx(getattr(s, f), rel=1e-9, abs=1e-12), f
    np.testing.assert_allclose(b.modal_share, s.modal_share, atol=1e-9)
    np.testing.assert_allclose(b.g, s.g, atol=1e-9)
    np.testing.assert_allclose(np.abs(b.omega), np.abs(s.omega), rtol=1e-9, atol=1e-9)
    assert b.message.split(" at q = ")[0] == s.message.split(" at q = ")[0]


def test_batched_evaluation_equals_single_on_30_designs_x_5_machs(designs):
    """evaluate_structures (batched per Mach) = evaluate_structure design by design: flutter points, modes, SDOFF
    flags, envelopes and constraints."""
    basis, modals, roms = designs
    kw = dict(zeta=0.01, mac_threshold=0.5, flutter_options=FLUTTER_OPTIONS)
    kw["benchmark"] = evaluate_structure(modals[0], basis, roms, **kw).envelope
    batched = evaluate_structures(modals, basis, roms, **kw)
    found = sdoff = 0
    for modal, b in zip(modals, batched, strict=True):
        s = evaluate_structure(modal, basis, roms, **kw)
        for rb, rs in zip(b.flutter, s.flutter, strict=True):
            assert_same_result(rb, rs)
            found += rs.flutter_found
            sdoff += rs.sdoff
        assert (b.sdoff, b.constraints_ok, b.message) == (s.sdoff, s.constraints_ok, s.message)
        assert b.envelope.status == s.envelope.status
        assert b.comparison.ok == s.comparison.ok
        np.testing.assert_allclose(b.comparison.margin_m, s.comparison.margin_m, rtol=1e-9, atol=1e-6)
        for f in ("q_flutter_pa", "q_safe_pa", "safe_altitude_m"):
            np.testing.assert_allclose(getattr(b.envelope, f), getattr(s.envelope, f), rtol=1e-9, atol=1e-9)
    assert found >= 100 and 10 <= sdoff <= found - 10  # crossings to refine, SDOFF flags both ways


@pytest.mark.parametrize("options", [
    {"sweep": "constant-speed", "zeta": None},
    {"sweep": "matched", "zeta": 0.01},
    {"sweep": "constant-density", "zeta": 0.01},
    {"sweep": "constant-speed", "zeta": 0.01, "coupling": "zoh"},
])
def test_flutter_batch_equals_flutter_analysis_other_sweeps(designs, options):
    """The other sweeps and couplings (and zero damping) of 10 designs at one Mach: batch = single."""
    _, modals, roms = designs
    rom, c_ref = roms[0.87]
    gamma = [np.linalg.lstsq(designs[0], m.shapes, rcond=None)[0] for m in modals[:10]]
    pairs = [(m.omega, to_modal(rom, g)) for m, g in zip(modals[:10], gamma, strict=True)]
    kw = dict(options, **({} if options["sweep"] == "matched" else FLUTTER_OPTIONS))
    for b, (om, aero) in zip(flutter_batch(pairs, c_ref, 0.87, **kw), pairs, strict=True):
        assert_same_result(b, flutter_analysis(om, aero, c_ref, 0.87, **kw))


def test_batch_shares_the_eigen_solves(designs):
    """A batch of 30 searches makes far fewer LAPACK calls than 30 single searches (one per round), on the same
    number of matrices."""
    basis, modals, roms = designs
    rom, c_ref = roms[0.79]
    pairs = [(m.omega, to_modal(rom, np.linalg.lstsq(basis, m.shapes, rcond=None)[0])) for m in modals]
    batch_mod.STATS.reset()
    flutter_batch(pairs, c_ref, 0.79, **FLUTTER_OPTIONS)
    calls_b, mats_b = batch_mod.STATS.eig_calls, batch_mod.STATS.matrices
    batch_mod.STATS.reset()
    for om, aero in pairs:
        flutter_analysis(om, aero, c_ref, 0.79, **FLUTTER_OPTIONS)
    assert mats_b == batch_mod.STATS.matrices
    assert calls_b * 5 < batch_mod.STATS.eig_calls


def test_brentq_generator_takes_scipys_steps():
    """The generator brentq returns scipy.optimize.brentq's root and evaluates f at the same points."""
    from scipy.optimize import brentq as scipy_brentq

    rng = np.random.default_rng(0)
    for _ in range(200):
        c = rng.normal(size=3)
        r0 = rng.uniform(0.05, 0.95)

        def g(x: float, c=c, r0=r0) -> float:
            return (x - r0) * (1.0 + 0.3 * c[0] * x + 0.3 * c[1] * x * x) + c[2] * (x - r0) ** 3

        seen_s: list[float] = []
        seen_g: list[float] = []

        def fs(x: float, seen_s: list[float] = seen_s) -> float:
            seen_s.append(x)
            return g(x)

        def fg(x: float, seen_g: list[float] = seen_g):
            seen_g.append(x)
            return g(x)
            yield  # a generator (no requests)

        try:
            ref = scipy_brentq(fs, 0.0, 1.0, xtol=1e-7, rtol=1e-4)
        except ValueError:
            continue
        assert batch_mod.run_one(brentq(fg, 0.0, 1.0, 1e-7, 1e-4)) == ref
        assert seen_g == seen_s
