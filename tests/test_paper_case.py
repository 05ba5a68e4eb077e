"""benchmarks.paper_case: the paper's tables regenerated in process, on a small case (about 15-30 s).

8 LHS samples, a 6-shape basis (worst sample MAC 0.9991: below the 0.9999 criterion, so ROM-AMS is less
accurate than with the full case's basis), ROMs at M 0.87 and 0.95 on 7 reduced frequencies, a DE of 2
generations of 6. Bound of the ROM-AMS vs ROM-PMS flutter-speed error: 2 %. Measured on this case: 0.21 % and
0.15 % (Table 5), -0.51 % and -0.47 % (Table 8 at M 0.87 and 0.95; frequencies within 0.37 %). The project's
validated accuracy with the 0.9999 basis is 1 % (romams.services.evaluation.VALIDATED_ERROR), and the
service's own estimate for a worst mode MAC of 0.997 is 0.3 sqrt(1 - 0.997) = 1.6 %, so 2 % leaves room
without hiding a broken ROM-AMS (wrong shapes give tens of percent: the same run's frozen-shape case is -38 %).
"""

from __future__ import annotations

import json
import math

import pytest

from benchmarks import paper_case

ERROR_BOUND_PCT = 2.0
MACHS = (0.87, 0.95)


@pytest.fixture(scope="module")
def result() -> dict:
    """The small case, run once for the module."""
    return paper_case.run(generations=2, popsize=6, machs=MACHS, samples=8, max_basis=6,
                          train_options={"k_values": [0.0, 0.05, 0.1, 0.2, 0.4, 0.8, 1.2]})


def test_contract_keys_and_json(result: dict) -> None:
    """Every key of the contract is filled and the result is JSON."""
    for key in ("table5", "table7", "table8", "fixed_mode_shapes_error_pct", "mass_reduction_pct", "solver",
                "settings", "timings_s", "optimum", "paper_optimum", "paper"):
        assert result[key] is not None, key
    json.loads(json.dumps(result))
    assert result["solver"] == "dlm"
    assert set(result["optimum"]) == set(result["paper_optimum"])
    assert result["evaluations"] == 6 * 3  # the initial population and 2 generations


def test_table5_pair_and_accuracy(result: dict) -> None:
    """Two different samples at M 0.87, ROM-AMS within 2 % of ROM-PMS in speed and frequency."""
    rows = result["table5"]
    assert [r["design"] for r in rows] == ["var1", "var2"]
    assert rows[0]["lhs_sample"] != rows[1]["lhs_sample"]
    assert result["table5_pair"]["mean_mode_mac_between_them"] < 0.9
    for r in rows:
        assert r["mach"] == 0.87
        assert r["v_rom_ams"] > 0 and r["v_rom_pms"] > 0
        assert math.isfinite(r["error_pct"]) and abs(r["error_pct"]) < ERROR_BOUND_PCT
        assert abs(r["omega_error_pct"]) < ERROR_BOUND_PCT


def test_table7_and_table8(result: dict) -> None:
    """Optimum: four fit MACs in (0.98, 1]; one accuracy row per Mach within the bound."""
    macs = [r["mac"] for r in result["table7"]]
    assert len(macs) == 4 and all(0.98 < m <= 1.0 + 1e-12 for m in macs)
    rows = result["table8"]
    assert [r["mach"] for r in rows] == list(MACHS)
    for r in rows:
        assert math.isfinite(r["error_pct"]) and abs(r["error_pct"]) < ERROR_BOUND_PCT
        assert r["paper"]["v_rom_ams"] > 0


def test_fixed_modes_and_mass(result: dict) -> None:
    """Frozen baseline mode shapes change the flutter speed a lot (the paper: -30 %); masses are sane."""
    fixed = result["fixed_mode_shapes"]
    assert fixed["v_fixed_modes"] > 0 and fixed["v_own_modes"] > 0
    assert abs(result["fixed_mode_shapes_error_pct"]) > 5.0
    assert result["baseline_mass_kg"] == pytest.approx(0.24, rel=1e-3)
    assert result["mass_reduction_pct"] == pytest.approx(
        100 * (result["baseline_mass_kg"] - result["optimum_mass_kg"]) / result["baseline_mass_kg"])
    assert result["paper"]["mass_reduction_pct"] == pytest.approx(28.46, abs=0.01)


def test_baseline_and_paper_optimum_rows(result: dict) -> None:
    """The benchmark's flutter rows at every Mach; the paper's Table 6 design evaluated (0.1668 kg here)."""
    base = result["baseline"]["flutter"]
    assert [r["mach"] for r in base] == list(MACHS)
    assert all(r["v"] > 0 and r["q_psi"] == pytest.approx(r["q_pa"] / 6894.757) for r in base)
    paper = result["paper_optimum_evaluated"]
    assert paper["mass_kg"] == pytest.approx(0.1668, rel=2e-3)
    assert len(paper["flutter"]) == len(MACHS)


def test_rom_dir_keeps_trained_roms_and_reads_them_back(tmp_path, monkeypatch) -> None:
    """``--rom-dir``: a ROM trained once is stored and read back unchanged; another identity trains anew."""
    import io

    import numpy as np

    from romams import serialize
    from romams.services.training import rom_identity
    from romams_core.basis import snapshot
    from romams_core.mesh import standard_mesh
    from romams_core.wing import cropped_delta

    wing = cropped_delta()
    mesh, shapes = standard_mesh(wing.planform), snapshot(wing, None, 2)
    ident = rom_identity("dlm", options={"k_values": [0.0, 0.1, 0.3, 0.6], "n_lags": 1}, wing=wing)
    trainer = paper_case.Trainer(1, tmp_path)
    (first,) = trainer.roms(mesh, shapes, [0.87], ident)
    assert len(list(tmp_path.glob("rom-M0.87-*.npz"))) == 1

    def no_training(*_a, **_k):
        raise AssertionError("a stored ROM was trained again")

    with monkeypatch.context() as m:
        m.setattr(paper_case, "train_shape_sets", no_training)
        (again,) = trainer.roms(mesh, shapes, [0.87], ident)
    (meta1, blob1), (meta2, blob2) = serialize.dumps(first), serialize.dumps(again)
    assert meta1 == meta2
    with np.load(io.BytesIO(blob1)) as a, np.load(io.BytesIO(blob2)) as b:
        assert a.files == b.files and all(np.array_equal(a[k], b[k]) for k in a.files)
    other = rom_identity("dlm", options={"k_values": [0.0, 0.1, 0.3, 0.7], "n_lags": 1}, wing=wing)
    trainer.roms(mesh, shapes, [0.87], other)
    assert len(list(tmp_path.glob("rom-M0.87-*.npz"))) == 2
