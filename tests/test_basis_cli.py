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
