"""ROM-AMS vs ROM-PMS flutter speed on random designs of the cropped delta wing, at the paper's five Machs.

ROM-PMS (the paper's reference) trains a ROM on each design's own modes with the same solver and settings (the
default: a rational-function ROM of the doublet-lattice GAFs); ROM-AMS transforms the one basis ROM per Mach to
the design's modes. Target: below 1 % in flutter speed for every design whose modes fit with MAC >= 0.99. The
full 20-design run with its distribution is ``python -m benchmarks.accuracy_rom_ams --fom 3`` (measured: speed
max 0.45 %, median 0.05 % over 100 cases; flutter frequency max 2.08 %, at M 0.79 on low-frequency mode-1
flutter, where the ROM-PMS fit is the farther from the full-order DLM p-k: ROM-AMS within 0.40 % of it,
ROM-PMS within 1.49 %); this test runs the first 3 of those seeded designs (15 cases) to stay within the CI budget.
"""

import pytest

from benchmarks.accuracy_rom_ams import run


@pytest.mark.slow
def test_rom_ams_matches_rom_pms_within_one_percent():
    res = run(n_designs=3, seed=7, processes=2)
    assert res["n_basis"] <= 8
    good = res["mac_ge_0_99"]
    assert good["n"] == 3 * 5  # every design fits the 8-shape basis with MAC >= 0.99
    assert good["found_mismatch"] == 0  # both methods find flutter (or both do not) at every Mach
    assert good["n_compared"] == good["n"]
    assert good["v_abs_error_pct"]["max"] < 1.0
    assert good["omega_abs_error_pct_max"] < 2.5  # the two RFA fits' own frequency scatter (docstring)
