"""``romams wing import / schema`` and ``--wing FILE`` with Nastran modes through typer's CliRunner."""

from __future__ import annotations

import json

import nastran_decks as nd  # tests/nastran_decks.py: skips this module without pyNastran (not under CI)
import numpy as np
import pytest
from typer.testing import CliRunner

from romams.cli import app
from romams_core.mesh import Planform

STICK = Planform(root_chord=0.3, tip_chord=0.3, semispan=0.5, sweep_le=0.0, n_chord=4, n_span=10)


def _run(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def test_wing_import_schema_and_flutter_with_op2_modes(data_dir):
    """Import the stick deck's planform, validate it against the schema, then flutter with the OP2's modes."""
    import jsonschema_rs

    bdf, op2, _, _ = nd.stick_deck(data_dir, STICK)
    out = data_dir / "stick.json"
    res = _run("wing", "import", bdf, "--out", out, "--name", "stick")
    assert res.exit_code == 0, res.output
    wing = json.loads(out.read_text())
    assert wing["structure"] is None and wing["planform"]["n_span"] == 10 and wing["planform"]["n_chord"] == 4
    schema = _run("wing", "schema")
    assert schema.exit_code == 0, schema.output
    jsonschema_rs.validator_for(json.loads(schema.stdout)).validate(wing)
    res = _run("flutter", "--wing", out, "--modes", op2, "--bdf", bdf, "--op2-modes", "3", "--mach", "0.5",
               "--json")
    assert res.exit_code == 0, res.output
    summary = json.loads(res.stdout)
    _, freqs, _ = nd.beam_modes(n_el=10, semispan=0.5)
    np.testing.assert_allclose(summary["frequencies_hz"], freqs[:3], rtol=1e-6)  # float32 eigenvalues in the OP2
    assert summary["n_basis"] == 3 and min(summary["mac"]) > 0.999999  # the external modes are the basis
    assert "planform-only: its 3 external modes are its basis" in res.stderr
    assert len(summary["results"]) == 1 and summary["results"][0]["mach"] == 0.5
    again = _run("flutter", "--wing", out, "--modes", op2, "--bdf", bdf, "--op2-modes", "3", "--mach", "0.5",
                 "--json")
    assert again.exit_code == 0 and "training" not in again.stderr  # same modes: the stored basis and ROM
    assert json.loads(again.stdout)["results"][0]["q_flutter_pa"] == pytest.approx(
        summary["results"][0]["q_flutter_pa"], rel=1e-9)


def test_cli_errors_name_the_option(data_dir):
    bdf, op2, _, _ = nd.stick_deck(data_dir, STICK, sym_xz=0)
    res = _run("wing", "import", bdf, "--name", "free", "--out", data_dir / "free.json")  # SYMXZ = 0: a free wing
    assert res.exit_code == 0 and json.loads((data_dir / "free.json").read_text())["symmetry"] == "none"
    free = ["flutter", "--wing", data_dir / "free.json", "--modes", op2, "--bdf", bdf, "--op2-modes", "3", "--mach",
            "0.5"]
    res = _run(*free, "--json")  # the dlm models the free wing (no mirror image at the root)
    assert res.exit_code == 0, res.output
    res = _run(*free[:-1], "0.3", "--solver", "tsd")  # every solver models a free wing: the tsd's own Mach check
    assert res.exit_code == 2 and "--mach" in res.output and "0.4" in res.output, res.output
    res = _run("wing", "import", bdf, "--symmetry", "mirrored")
    assert res.exit_code == 2 and "--symmetry" in res.output
    res = _run("wing", "import", bdf, "--symmetry", "symmetric", "--out", data_dir / "w.json")
    assert res.exit_code == 0, res.output
    wing = data_dir / "w.json"
    res = _run("flutter", "--wing", wing, "--mach", "0.5")
    assert res.exit_code == 2 and "planform-only" in res.output and "--modes" in res.output
    res = _run("modal", "--wing", wing)
    assert res.exit_code == 2 and "planform-only" in res.output
    res = _run("flutter", "--wing", wing, "--modes", op2, "--bdf", bdf, "--op2-modes", "1,9", "--mach", "0.5")
    assert res.exit_code == 2 and "--op2-modes" in res.output and "[9]" in res.output
    res = _run("flutter", "--wing", wing, "--modes", op2, "--bdf", bdf, "--spline", "surface", "--mach", "0.5")
    assert res.exit_code == 2 and "collinear" in res.output
    assert "Traceback" not in res.output
