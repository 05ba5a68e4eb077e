"""POST /api/v1/wings/{wing}/basis/snapshots: a PCA basis from uploaded mode sets (POST /modes). 20 built-in plate
designs stand in for "external" ones: the basis equals the built-in LHS basis of the same designs, and a new design
evaluated from its uploaded modes equals the built-in design path, within 1e-9."""

from __future__ import annotations

import io

import numpy as np
import pytest
from fastapi.testclient import TestClient

from api.app import create_app
from romams.settings import Settings
from romams_core.basis import build_basis_for_wing, project, sample_designs
from romams_core.mesh import standard_mesh
from romams_core.structure.modal import modal_analysis
from romams_core.wing import template

from .conftest import SentTasks

N_SETS, MODES = 20, 4


@pytest.fixture(scope="module")
def api(tmp_path_factory):
    app = create_app(Settings(data_dir=tmp_path_factory.mktemp("snapshots")), celery=SentTasks(), sweeper=False)
    with TestClient(app) as c:
        yield c, app.state.service.store


def _npz(modal, mesh) -> bytes:
    """A built-in design's modes written as an uploaded mode set (NPZ on the standard-mesh nodes, unit masses)."""
    buf = io.BytesIO()
    np.savez(buf, nodes=np.column_stack([mesh.x, mesh.y, np.zeros(mesh.n_nodes)]), shapes=modal.shapes,
             frequencies_hz=modal.frequencies_hz, generalized_masses=np.ones(modal.shapes.shape[1]))
    return buf.getvalue()


def _upload(c, data: bytes) -> int:
    r = c.post("/api/v1/modes", files={"file": ("modes.npz", data)})
    assert r.status_code == 201, r.text
    return r.json()["id"]


def test_uploaded_snapshots_give_the_built_in_basis_and_evaluations(api):
    from romams.services.evaluation import Models, evaluate, structure_modal
    from romams_core.aero.dlm import DlmSolver
    from romams_core.training_rfa import train_rfa_rom

    c, store = api
    wing = template("cropped-delta")
    mesh = standard_mesh(wing.planform)
    wid = c.post("/api/v1/wings", json={"template": "cropped-delta", "name": "cd-snapshots"}).json()["id"]
    designs = sample_designs(wing, N_SETS, seed=0)
    ids = [_upload(c, _npz(modal_analysis(wing, x, MODES, mesh), mesh)) for x in designs]
    r = c.post(f"/api/v1/wings/{wid}/basis/snapshots", json={"modes_ids": ids, "modes": MODES})
    assert r.status_code == 201, r.text
    out = r.json()
    assert out["params"]["snapshots"] == ids and c.get(f"/api/v1/wings/{wid}").json()["active_basis_id"] == out["id"]
    mine = store.bases.load(out["id"])
    ref = build_basis_for_wing(wing, samples=N_SETS, modes=MODES, mac_threshold=0.9999, max_basis=12, seed=0)
    assert mine.n_basis == ref.n_basis == out["n_basis"]
    signs = np.sign(np.sum(mine.shapes * ref.shapes, axis=0))  # a PCA vector's sign is arbitrary
    np.testing.assert_allclose(mine.shapes * signs, ref.shapes, rtol=0, atol=1e-9 * np.abs(ref.shapes).max())
    # a new design: its uploaded modes on the snapshot basis vs the built-in design on the built-in basis, with the
    # built-in basis' ROM (the bases agree within 1e-9): within 1e-9
    x = sample_designs(wing, 1, seed=99)[0]
    path = store.modes.load(_upload(c, _npz(modal_analysis(wing, x, MODES, mesh), mesh)))
    rom = train_rfa_rom(mesh, ref.shapes, 0.87, DlmSolver(refine=1))

    def flutter(basis, rom, design, modes):
        models = Models(wid, wing, mesh, 0, basis, {0.87: (0, rom)})
        modal = structure_modal(models, design, modes)
        assert project(basis.shapes, modal.shapes).mac.min() > 0.99
        return evaluate(models, modal).flutter[0]

    a, b = flutter(mine, rom, None, path), flutter(ref, rom, x, None)
    assert a.flutter_found and a.flutter_mode == b.flutter_mode
    assert a.q_flutter_pa == pytest.approx(b.q_flutter_pa, rel=1e-9)
    assert a.omega_flutter_rad_s == pytest.approx(b.omega_flutter_rad_s, rel=1e-9)
    # with a ROM trained on each basis: the RFA's lag-root optimization turns the 1e-9 basis differences into
    # about 7e-6 in q_f (measured), so the whole path agrees to that level
    own = flutter(mine, train_rfa_rom(mesh, mine.shapes, 0.87, DlmSolver(refine=1)), None, path)
    assert own.flutter_mode == b.flutter_mode and own.q_flutter_pa == pytest.approx(b.q_flutter_pa, rel=1e-4)


def test_bad_snapshot_requests_are_refused_and_store_nothing(api):
    c, store = api
    wing = template("cropped-delta")
    mesh = standard_mesh(wing.planform)
    wid = c.post("/api/v1/wings", json={"template": "cropped-delta", "name": "cd-bad-snapshots"}).json()["id"]
    one = _upload(c, _npz(modal_analysis(wing, None, 2, mesh), mesh))
    for body, status, field in (({"modes_ids": [one]}, 422, "modes_ids"),
                                ({"modes_ids": [one, 999999]}, 404, "modes_ids[1]"),
                                ({"modes_ids": [one, one], "modes": 3}, 422, "modes_ids[0]"),  # 2 modes per set
                                ({"modes_ids": [one, one], "mac_threshold": 1.5}, 422, "mac_threshold")):
        r = c.post(f"/api/v1/wings/{wid}/basis/snapshots", json=body)
        assert r.status_code == status and r.json()["field"] == field, r.text
    assert c.get(f"/api/v1/wings/{wid}/bases").json() == []
