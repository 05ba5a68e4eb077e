"""``romams pk``: p-k flutter of one structure from a GAF table on its own modes (no basis, no ROM)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from romams.cli import app
from romams.settings import get_settings
from romams_core.aero.dlm import DlmSolver
from romams_core.gaf_table import GafTable, gaf_npz
from romams_core.mesh import standard_mesh
from romams_core.pk import AeroTable, pk_flutter
from romams_core.pk_reference import fom_flutter
from romams_core.structure.modal import modal_analysis
from romams_core.wing import template

K = np.array([0.0, 0.02, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.7, 0.9, 1.2, 1.6, 2.0])


@pytest.fixture()
def baseline(tmp_path, monkeypatch):
    """Cropped-delta baseline: 4 mass-normalized modes, and the DLM's GAF on them at M 0.87 (refine 1)."""
    monkeypatch.setenv("ROMAMS_DATA_DIR", str(tmp_path / "data"))
    get_settings.cache_clear()
    wing = template("cropped-delta")
    mesh = standard_mesh(wing.planform)
    modal = modal_analysis(wing, None, 4, mesh)
    h = DlmSolver(refine=1).gaf(mesh, modal.shapes, 0.87, K)
    yield wing, mesh, modal, h
    get_settings.cache_clear()


def _files(tmp_path, mesh, modal, h, scale: float):
    """Modes NPZ (shapes x scale, generalized masses scale^2) and the table NPZ on those scaled modes."""
    modes = tmp_path / f"modes{scale:g}.npz"
    np.savez(modes, nodes=mesh.nodes, shapes=modal.shapes * scale, frequencies_hz=modal.frequencies_hz,
             generalized_masses=np.full(4, scale ** 2))
    table = tmp_path / f"table{scale:g}.npz"
    table.write_bytes(gaf_npz(GafTable(0.87, K, h * scale ** 2)))
    return modes, table


def test_pk_from_an_own_mode_table_equals_the_core_p_k(tmp_path, baseline):
    """The command's flutter point equals pk_flutter on the same table (1e-9), for mass-normalized modes and for
    modes scaled by 2 (generalized masses 4, table on the scaled modes: normalized back); and it agrees with the
    full-order DLM p-k of the benchmarks (its own k grid plus the exact GAF at the flutter k) within 1e-4."""
    wing, mesh, modal, h = baseline
    ref = pk_flutter(modal.omega, AeroTable(k=K, h=h, mach=0.87), mesh.c_ref, 0.87, zeta=wing.modal_damping)
    assert ref.flutter_found
    for scale in (1.0, 2.0):
        modes, table = _files(tmp_path, mesh, modal, h, scale)
        res = CliRunner().invoke(app, ["pk", "--modes", str(modes), "--gaf", str(table), "--json"])
        assert res.exit_code == 0, res.output
        out = json.loads(res.stdout)
        assert out["q_flutter_pa"] == pytest.approx(ref.q_flutter_pa, rel=1e-9)
        assert out["f_flutter_hz"] == pytest.approx(ref.omega_flutter_rad_s / (2 * np.pi), rel=1e-9)
        assert out["flutter_mode"] == ref.flutter_mode and out["mach"] == 0.87
    fom, _ = fom_flutter(mesh, modal.omega, modal.shapes, 0.87, zeta=wing.modal_damping, solver=DlmSolver(refine=1))
    assert out["q_flutter_pa"] == pytest.approx(fom.q_flutter_pa, rel=1e-4)  # measured 4.2e-6
    text = CliRunner().invoke(app, ["pk", "--modes", str(modes), "--gaf", str(table)])
    assert text.exit_code == 0 and "flutter at V" in text.stdout and "mode" in text.stdout


def test_pk_usage_errors_name_the_option(tmp_path, baseline):
    _, mesh, modal, h = baseline
    modes, table = _files(tmp_path, mesh, modal, h, 1.0)
    three = tmp_path / "three.npz"
    three.write_bytes(gaf_npz(GafTable(0.87, K, h[:, :3, :3])))
    res = CliRunner().invoke(app, ["pk", "--modes", str(modes), "--gaf", str(three)])
    assert res.exit_code == 2 and "--gaf" in res.output and "3 modes" in res.output
    res = CliRunner().invoke(app, ["pk", "--modes", str(modes), "--gaf", str(table), "--k-values", "0,0.1"])
    assert res.exit_code == 2 and "--k-values" in res.output
    res = CliRunner().invoke(app, ["pk", "--modes", str(modes), "--gaf", str(tmp_path / "missing.npz")])
    assert res.exit_code == 2 and "missing.npz" in res.output and str(tmp_path) not in res.output
