"""``romams train`` through typer's CliRunner: JSON contract, plots, reuse of the stored ROM, bad input."""

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from romams.cli import app
from romams.persistence import open_store


def test_train_command_json_plots_and_store(data_dir):
    plots = data_dir / "plots"
    runner = CliRunner()
    args = ["train", "--wing", "cropped-delta", "--mach", "0.87", "--solver", "uvlm", "--n-steps", "1200", "--json",
            "--plot", str(plots)]
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    rep = json.loads(res.stdout)
    for key in ("rom_id", "mach", "n_basis", "validation_nrmse", "train_seconds"):
        assert key in rep
    assert rep["mach"] == pytest.approx(0.87)
    assert len(rep["validation_nrmse"]) == rep["n_basis"] >= 1
    assert max(rep["validation_nrmse"]) < 0.01
    assert "building the PCA basis" in res.stderr
    for p in rep["plots"]:
        with open(p, "rb") as fh:
            assert fh.read(8) == b"\x89PNG\r\n\x1a\n"
    rom = open_store().roms.load(rep["rom_id"])
    np.testing.assert_allclose(rom.validation_nrmse, rep["validation_nrmse"], rtol=1e-12)
    assert rom.ss.is_stable()
    # the same request again finds the stored ROM instead of retraining
    again = json.loads(runner.invoke(app, ["train", "--mach", "0.87", "--solver", "uvlm", "--n-steps", "1200",
                                           "--json"]).stdout)
    assert again["rom_id"] == rep["rom_id"]


def test_train_command_default_dlm_rational_function_rom(data_dir):
    """The default solver is the doublet lattice: a GAF table fitted by an RFA (fit error <= 1 % per entry)."""
    plots = data_dir / "plots-dlm"
    runner = CliRunner()
    fast = ["--lattice-refine", "1"]  # one box per panel (the lattice is not what is tested here)
    res = runner.invoke(app, ["train", "--mach", "0.87", *fast, "--json", "--plot", str(plots)])
    assert res.exit_code == 0, res.output
    rep = json.loads(res.stdout)
    assert rep["solver"] == "dlm" and rep["kind"] == "rfa" and rep["na"] == rep["nb"] == 0
    assert rep["dt_star"] == 0.0 and rep["fit_error_max"] <= 0.01 and 1 <= rep["n_lags"] <= 8
    assert len(rep["validation_nrmse"]) == rep["n_basis"] and max(rep["validation_nrmse"]) == rep["fit_error_max"]
    fe = np.array(rep["fit_error"])  # worst weighted error over the k table, per entry
    assert fe.shape == (rep["n_basis"], rep["n_basis"]) and fe.max() == rep["fit_error_max"]
    (png,) = rep["plots"]
    with open(png, "rb") as fh:
        assert fh.read(8) == b"\x89PNG\r\n\x1a\n"
    rom = open_store().roms.load(rep["rom_id"])
    assert rom.ss.is_stable() and rom.ss.D2 is not None and "refined 1x" in rom.solver_description
    again = runner.invoke(app, ["train", "--mach", "0.87", *fast, "--json"])
    assert json.loads(again.stdout)["rom_id"] == rep["rom_id"]
    # ARX settings do not apply to the dlm, RFA settings not to the uvlm
    bad = runner.invoke(app, ["train", "--mach", "0.87", "--n-steps", "1200"])
    assert bad.exit_code == 2 and "ARX" in bad.output
    bad = runner.invoke(app, ["train", "--mach", "0.87", "--solver", "uvlm", "--n-lags", "2"])
    assert bad.exit_code == 2 and "--n-lags" in bad.output
    bad = runner.invoke(app, ["train", "--mach", "0.87", "--solver", "uvlm", "--lattice-refine", "1"])
    assert bad.exit_code == 2 and "--lattice-refine" in bad.output
    bad = runner.invoke(app, ["train", "--mach", "0.87", "--lattice-refine", "5"])
    assert bad.exit_code == 2 and "--lattice-refine" in bad.output
    bad = runner.invoke(app, ["train", "--mach", "0.87", "--solver", "vlm"])
    assert bad.exit_code == 2 and "unknown solver" in bad.output


def test_train_command_rejects_bad_input(data_dir):
    runner = CliRunner()
    res = runner.invoke(app, ["train", "--wing", "no-such-wing"])
    assert res.exit_code == 2 and "unknown template" in res.output
    res = runner.invoke(app, ["train", "--reduce", "lots"])
    assert res.exit_code == 2 and "--reduce" in res.output
