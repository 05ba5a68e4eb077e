"""``romams basis`` through typer's CliRunner: JSON contract, NPZ output, plots, the local store."""

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from romams.cli import app
from romams.persistence import open_store


def test_basis_command_json_npz_plots_and_store(data_dir):
    out = data_dir / "basis.npz"
    plots = data_dir / "plots"
    args = ["basis", "--wing", "cropped-delta", "--samples", "6", "--modes", "3", "--mac", "0.98", "--seed", "1",
            "--max-basis", "6", "--holdout", "3", "--json", "--out", str(out), "--plot", str(plots)]
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 0, res.output
    rep = json.loads(res.stdout)
    for key in ("n_basis", "min_mac_samples", "holdout_min_mac", "holdout_min_mac_by_mode", "singular_values",
                "capped", "basis_id", "wing_id"):
        assert key in rep
    assert 1 <= rep["n_basis"] <= 6
    assert rep["capped"] or rep["min_mac_samples"] >= 0.98
    assert len(rep["holdout_min_mac_by_mode"]) == 3
    assert rep["holdout_min_mac"] == pytest.approx(min(rep["holdout_min_mac_by_mode"]), abs=1e-6)
    assert 0.5 < rep["holdout_min_mac"] <= 1.0
    with np.load(out, allow_pickle=False) as z:
        shapes = z["shapes"]
        assert int(z["n_basis"]) == rep["n_basis"]
        assert z["designs"].shape == (6, 7)
        assert z["design_names"].tolist() == [f"x{i}" for i in range(1, 8)]
    np.testing.assert_allclose(shapes.T @ shapes, np.eye(rep["n_basis"]), atol=1e-12)
    for name in ("basis_shapes.png", "mac_vs_basis_size.png", "fit_comparison.png"):
        assert (plots / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    store = open_store()
    bid, stored = store.bases.latest(rep["wing_id"])
    assert bid == rep["basis_id"]
    np.testing.assert_array_equal(stored.shapes, shapes)
    assert stored.min_mac == pytest.approx(rep["min_mac_samples"], abs=1e-6)


def test_basis_command_rejects_bad_input(data_dir):
    runner = CliRunner()
    res = runner.invoke(app, ["basis", "--wing", "no-such-wing", "--no-store", "--samples", "2"])
    assert res.exit_code == 2 and "unknown template" in res.output
    res = runner.invoke(app, ["basis", "--mac", "1.0", "--no-store", "--samples", "2"])
    assert res.exit_code == 2 and "--mac" in res.output


def test_basis_from_user_mode_sets(tmp_path, monkeypatch):
    """``romams basis --snapshots F1 F2 ...``: the basis of the user's mode sets equals the built-in LHS basis of
    the same designs (1e-9); a set with too few modes is a usage error naming --snapshots."""
    import numpy as np

    from romams.persistence import open_store
    from romams.settings import get_settings
    from romams_core.basis import build_basis_for_wing, sample_designs
    from romams_core.mesh import standard_mesh
    from romams_core.structure.modal import modal_analysis
    from romams_core.wing import template

    monkeypatch.setenv("ROMAMS_DATA_DIR", str(tmp_path / "data"))
    get_settings.cache_clear()
    wing = template("cropped-delta")
    mesh = standard_mesh(wing.planform)
    files = []
    for i, x in enumerate(sample_designs(wing, 8, seed=0)):
        m = modal_analysis(wing, x, 3, mesh)
        files.append(tmp_path / f"design{i}.npz")
        np.savez(files[-1], nodes=np.column_stack([mesh.x, mesh.y, np.zeros(mesh.n_nodes)]), shapes=m.shapes,
                 frequencies_hz=m.frequencies_hz, generalized_masses=np.ones(3))
    args = ["basis", "--modes", "3", "--mac", "0.999", "--json", *[a for f in files for a in ("--snapshots", str(f))]]
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 0, res.output
    rep = json.loads(res.stdout)
    mine = open_store().bases.load(rep["basis_id"])
    ref = build_basis_for_wing(wing, samples=8, modes=3, mac_threshold=0.999, seed=0)
    assert mine.n_basis == ref.n_basis == rep["n_basis"] and rep["samples"] == 8
    signs = np.sign(np.sum(mine.shapes * ref.shapes, axis=0))
    np.testing.assert_allclose(mine.shapes * signs, ref.shapes, atol=1e-9 * np.abs(ref.shapes).max())
    bad = CliRunner().invoke(app, ["basis", "--modes", "5", "--snapshots", str(files[0]), "--snapshots",
                                   str(files[1])])
    assert bad.exit_code == 2 and "--snapshots" in bad.output and "design0.npz" in bad.output
    get_settings.cache_clear()
