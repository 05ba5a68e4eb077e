"""The GAF correction of benchmarks.tsd_ams_gap: a ROM corrected to direct harmonic columns returns them exactly at
the anchors, is linear in k between them, and moves a ROM's flutter point onto that of the exact GAF."""

from __future__ import annotations

import numpy as np
from test_pk import HP, section_h

from benchmarks.tsd_ams_gap import corrected_aero, pk_point
from romams_core.statespace import DiscreteSS
from romams_core.typical_section import jones_discrete, modes


def _ss(seed: int, m: int = 2, n: int = 6) -> DiscreteSS:
    """A stable random discrete model with m inputs and outputs (step 0.1 t*)."""
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(n, n))
    a *= 0.9 / max(abs(np.linalg.eigvals(a)))
    return DiscreteSS(A=a, B=rng.normal(size=(n, m)), C=0.05 * rng.normal(size=(m, n)),
                      D=np.diag([0.2, 1.0]) + 0.05 * rng.normal(size=(m, m)), dt_star=0.1)


def test_corrected_gaf_is_the_direct_one_at_the_anchors_and_linear_between() -> None:
    ks = np.array([0.05, 0.1, 0.2])
    ss = _ss(0)
    direct = ss.freqresp(ks) * (1.0 + 0.1j) + 0.01
    aero = corrected_aero(ss, ks, direct)
    np.testing.assert_allclose(aero(ks), direct, rtol=1e-12, atol=1e-14)
    delta = direct - ss.freqresp(ks)
    mid = aero(np.array([0.075, 0.3]))
    np.testing.assert_allclose(mid[0] - ss.freqresp(np.array([0.075]))[0], 0.5 * (delta[0] + delta[1]), atol=1e-14)
    np.testing.assert_allclose(mid[1] - ss.freqresp(np.array([0.3]))[0], delta[2], atol=1e-14)  # held outside


def test_a_rom_corrected_to_exact_columns_flutters_where_the_exact_gaf_does() -> None:
    """The typical section: its Jones discrete model (an approximation of Theodorsen's function, with BDF input
    derivatives at dt* 0.1) corrected to the exact Theodorsen GAF at k anchors 0.05 apart lands within 0.1 % of
    the exact p-k flutter speed; uncorrected it is farther away."""
    omega, _ = modes(HP)
    ks = np.round(np.arange(0.0, 1.001, 0.05), 6)
    rom = jones_discrete(HP, 0.1)
    ref = pk_point(lambda k: section_h(np.atleast_1d(k)), omega, HP.c_ref, 0.3, 0.0)
    raw = pk_point(lambda k: rom.freqresp(np.atleast_1d(k)), omega, HP.c_ref, 0.3, 0.0)
    fixed = pk_point(corrected_aero(rom, ks, section_h(ks)), omega, HP.c_ref, 0.3, 0.0)
    assert ref["v_eas"] is not None and raw["v_eas"] is not None and fixed["v_eas"] is not None
    err_raw, err_fixed = abs(raw["v_eas"] / ref["v_eas"] - 1.0), abs(fixed["v_eas"] / ref["v_eas"] - 1.0)
    assert err_fixed < 1e-3
    assert err_fixed < 0.5 * err_raw
