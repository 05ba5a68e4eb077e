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
    for args, hint in ((["--solver", "tsd", "--anchor-k", "0.05,2"], "options.anchor_k"),
                       (["--solver", "tsd", "--anchor-k", "low"], "--anchor-k"),
                       (["--solver", "uvlm", "--anchor-k", "0.05"], "--anchor-k"),
                       (["--solver", "tsd", "--coefficients", "krupp"], "options.coefficients"),
                       (["--solver", "dlm", "--coefficients", "nlr"], "--coefficients"),
                       (["--solver", "tsd", "--supercritical-refine", "0.5"], "options.supercritical_refine"),
                       (["--solver", "tsd", "--supercritical-refine", "fine"], "--supercritical-refine"),
                       (["--solver", "dlm", "--supercritical-refine", "2"], "applies to the transonic solver")):
        res = runner.invoke(app, ["train", "--mach", "0.9", *args])
        assert res.exit_code == 2 and hint in res.output, res.output


def test_gaf_table_export_import_and_flutter_with_the_imported_model(data_dir):
    """``romams train --export-gaf`` writes the DLM ROM's table; ``--gaf FILE --label L`` imports it as the ROM of
    solver external:L (the same RFA fit); ``romams flutter --solver external:L`` uses it: the same flutter point as
    the DLM ROM it came from. Bad tables are usage errors naming the option, and nothing is stored."""
    from romams.pipeline import cli_models, resolve_wing, rom_identity
    from romams.services.evaluation import evaluate_structure_summary
    from romams_core.gaf_table import GafTable, gaf_npz

    runner = CliRunner()
    table = data_dir / "dlm_M0.87.npz"
    res = runner.invoke(app, ["train", "--mach", "0.87", "--lattice-refine", "1", "--export-gaf", str(table),
                              "--json"])
    assert res.exit_code == 0, res.output
    dlm = json.loads(res.stdout)
    res = runner.invoke(app, ["train", "--gaf", str(table), "--label", "copy", "--json"])
    assert res.exit_code == 0, res.output
    ext = json.loads(res.stdout)
    assert ext["solver"] == "external:copy" and ext["kind"] == "rfa" and ext["mach"] == 0.87
    assert ext["rom_id"] != dlm["rom_id"] and ext["fit_error_max"] == pytest.approx(dlm["fit_error_max"], rel=1e-9)
    res = runner.invoke(app, ["flutter", "--baseline", "--mach", "0.87", "--solver", "external:copy", "--json"])
    assert res.exit_code == 0, res.output
    (r_ext,) = json.loads(res.stdout)["results"]
    st = open_store()
    wid, w = resolve_wing(st, "cropped-delta")
    models = cli_models(st, wid, w, [0.87], rom_identity("dlm", options={"lattice_refine": 1}))
    (r_dlm,) = evaluate_structure_summary(models)[0]["results"]
    assert r_ext["solver"] == "external:copy" and r_ext["flutter_mode"] == r_dlm["flutter_mode"]
    assert r_ext["q_flutter_pa"] == pytest.approx(r_dlm["q_flutter_pa"], rel=1e-9)

    n_roms = len(st.roms.of_wing(wid))
    bad = data_dir / "bad.npz"
    bad.write_bytes(gaf_npz(GafTable(0.87, np.array([0.0, 0.1, 0.3, 0.6]), np.zeros((4, 2, 2)))))
    for args, hint in ((["--gaf", str(table)], "--label"),
                       (["--gaf", str(bad), "--label", "two"], "--gaf"),  # 2 shapes, the basis has more
                       (["--gaf", str(table), "--label", "a b"], "--label"),
                       (["--gaf", str(data_dir / "missing.npz"), "--label", "x"], "--gaf")):
        res = runner.invoke(app, ["train", *args])
        assert res.exit_code == 2 and hint in res.output, res.output
    assert len(st.roms.of_wing(wid)) == n_roms
    res = runner.invoke(app, ["flutter", "--baseline", "--mach", "0.79", "--solver", "external:copy"])
    assert res.exit_code == 2 and "--solver" in res.output and "import" in res.output


def test_nastran_qhh_op4_import_from_the_cli(data_dir):
    """The DLM ROM's table written as Nastran's QHH (an ASCII OUTPUT4 of h rows and h x nk columns) and imported
    with ``--gaf qhh.op4 --mach 0.87 --k-values ...`` flutters like the DLM ROM; a missing k list or a wrong
    matrix name is a usage error naming the option, and nothing is stored."""
    from pyNastran.op4.op4 import write_op4

    from romams.pipeline import cli_models, resolve_wing, rom_identity
    from romams.services.evaluation import evaluate_structure_summary

    runner = CliRunner()
    npz = data_dir / "dlm_M0.87.npz"
    res = runner.invoke(app, ["train", "--mach", "0.87", "--lattice-refine", "1", "--export-gaf", str(npz)])
    assert res.exit_code == 0, res.output
    with np.load(npz) as z:
        k, gaf = z["k"], z["gaf_real"] + 1j * z["gaf_imag"]
    op4 = data_dir / "qhh.op4"
    write_op4(str(op4), {"QHH": (2, np.hstack(list(gaf)))}, is_binary=False, precision="double")
    k_text = ",".join(repr(float(x)) for x in k)
    st = open_store()
    wid, w = resolve_wing(st, "cropped-delta")
    n_roms = len(st.roms.of_wing(wid))
    for args, hint in ((["--mach", "0.87"], "--k-values"),
                       (["--mach", "0.87", "--k-values", k_text, "--matrix", "KHH"], "--matrix"),
                       (["--mach", "0.87", "--k-values", k_text[: k_text.rindex(",")]], "--k-values"),
                       (["--k-values", k_text], "--mach")):
        res = runner.invoke(app, ["train", "--gaf", str(op4), "--label", "nas", *args])
        assert res.exit_code == 2 and hint in res.output, res.output
    res = runner.invoke(app, ["train", "--matrix", "QHH"])  # QHH settings without a --gaf file
    assert res.exit_code == 2 and "--matrix" in res.output, res.output
    assert len(st.roms.of_wing(wid)) == n_roms
    res = runner.invoke(app, ["train", "--gaf", str(op4), "--label", "nas", "--mach", "0.87", "--k-values", k_text,
                              "--json"])
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout)["solver"] == "external:nas"
    res = runner.invoke(app, ["flutter", "--baseline", "--mach", "0.87", "--solver", "external:nas", "--json"])
    assert res.exit_code == 0, res.output
    (r_ext,) = json.loads(res.stdout)["results"]
    models = cli_models(st, wid, w, [0.87], rom_identity("dlm", options={"lattice_refine": 1}))
    (r_dlm,) = evaluate_structure_summary(models)[0]["results"]
    assert r_ext["flutter_mode"] == r_dlm["flutter_mode"]
    assert r_ext["q_flutter_pa"] == pytest.approx(r_dlm["q_flutter_pa"], rel=1e-9)  # the issue asks 0.1 %


def test_external_cfd_package_round_trip_from_the_cli(data_dir):
    """``romams train --export-package`` -> the UVLM run as the external code on the package's files -> ``romams
    train --gac FILE --label L --settings settings.json`` -> ``romams flutter --solver external:L``."""
    import io
    import zipfile

    from romams_core.aero.uvlm import UvlmSolver
    from romams_core.mesh import standard_mesh
    from romams_core.wing import template

    runner = CliRunner()
    pkg = data_dir / "package.zip"
    res = runner.invoke(app, ["train", "--mach", "0.6", "--na", "6", "--nb", "6", "--export-package", str(pkg)])
    assert res.exit_code == 0, res.output
    with zipfile.ZipFile(pkg) as z:
        arrays = np.load(io.BytesIO(z.read("excitation.npz")))
        (data_dir / "settings.json").write_bytes(z.read("settings.json"))
    mesh = standard_mesh(template("cropped-delta").planform)
    gac = UvlmSolver(refine=1).simulate(mesh, arrays["shapes"], arrays["signals"], 0.6, float(arrays["dt_star"]))
    m = gac.shape[1]
    (data_dir / "gac.csv").write_text(",".join(f"g_{j}" for j in range(m)) + "\n"
                                      + "\n".join(",".join(repr(float(v)) for v in row) for row in gac) + "\n")
    res = runner.invoke(app, ["train", "--gac", str(data_dir / "gac.csv"), "--label", "cfd", "--settings",
                              str(data_dir / "settings.json"), "--json"])
    assert res.exit_code == 0, res.output
    rep = json.loads(res.stdout)
    assert rep["solver"] == "external:cfd" and rep["mach"] == 0.6 and rep["na"] == 6
    assert max(rep["validation_nrmse"]) < 0.02
    res = runner.invoke(app, ["flutter", "--baseline", "--mach", "0.6", "--solver", "external:cfd", "--json"])
    assert res.exit_code == 0, res.output
    (r,) = json.loads(res.stdout)["results"]
    assert r["solver"] == "external:cfd" and r["rom_id"] == rep["rom_id"] and r["flutter_found"]
    res = runner.invoke(app, ["train", "--gac", str(data_dir / "gac.csv"), "--label", "cfd"])
    assert res.exit_code == 2 and "--settings" in res.output
