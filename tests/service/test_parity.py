"""One evaluation path: the CLI (``--json``), the HTTP API (real worker) and an in-process call of the use case
give identical numbers (to 1e-9) and identical keys for the same design, wing and ROMs."""

from __future__ import annotations

import json
import math

import pytest
from fastapi.testclient import TestClient
from typer.testing import CliRunner

from api.app import create_app
from romams.cli import app as cli
from romams.settings import Settings, get_settings

from .conftest import WorkerProcess, service_env

DESIGN = {"x1": 0.3, "x2": 0.4, "x3": 0.7, "x4": 0.05, "x5": 1.0, "x6": 1.0, "x7": 0.8}
MACHS = [0.79, 0.87]
#: keys that only say how a result travelled (job, stored row, plots), not what it is
TRANSPORT = {"job_id", "evaluation_id", "cached", "plots"}


def _assert_same(a, b, path="summary"):
    """Same structure, same keys, numbers equal to 1e-9 (relative), other values equal."""
    if isinstance(a, dict):
        assert isinstance(b, dict), path
        ka, kb = set(a) - TRANSPORT, set(b) - TRANSPORT
        assert ka == kb, f"{path}: keys differ: {sorted(ka ^ kb)}"
        for k in ka:
            _assert_same(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _assert_same(x, y, f"{path}[{i}]")
    elif isinstance(a, float) and not isinstance(a, bool):
        assert isinstance(b, int | float) and not isinstance(b, bool), path
        assert (math.isnan(a) and math.isnan(b)) or a == pytest.approx(b, rel=1e-9, abs=1e-12), f"{path}: {a} != {b}"
    else:
        assert a == b, f"{path}: {a!r} != {b!r}"


def test_cli_api_and_in_process_give_identical_results(tmp_path, monkeypatch):
    data = tmp_path / "data"
    monkeypatch.setenv("ROMAMS_DATA_DIR", str(data))
    monkeypatch.delenv("ROMAMS_DATABASE_URL", raising=False)
    get_settings.cache_clear()
    design = ",".join(f"{k}={v}" for k, v in DESIGN.items())
    # 1. the CLI builds the wing's first basis (which becomes its active basis) and trains the ROMs
    res = CliRunner().invoke(cli, ["flutter", "--wing", "cropped-delta", "--design", design, "--mach", "0.79",
                                   "--mach", "0.87", "--samples", "6", "--mac", "0.999", "--json"])
    assert res.exit_code == 0, res.output
    from_cli = json.loads(res.stdout)
    assert [r["mach"] for r in from_cli["results"]] == MACHS
    assert from_cli["flight_condition"]["sweep"] == "constant-speed"

    # 2. in-process: the use case on the stored models
    from romams.persistence import open_store
    from romams.pipeline import resolve_wing
    from romams.services.evaluation import evaluate_structure_summary
    from romams.services.models import load_models, resolve_basis_id, trained_rom_ids
    from romams_core.mesh import standard_mesh

    store = open_store()
    wid, wing = resolve_wing(store, "cropped-delta")
    bid = resolve_basis_id(store, wid)
    assert bid == from_cli["basis_id"]
    models = load_models(wid, wing, bid, trained_rom_ids(store, wid, bid), store.bases.load, store.roms.load,
                         lambda _: standard_mesh(wing.planform))
    in_process, _ = evaluate_structure_summary(models, design=DESIGN)

    # 3. the HTTP API with a real worker on the same store
    settings = Settings(data_dir=data, sync_timeout_s=120)
    worker = WorkerProcess(service_env(data), data.parent / "worker.log")
    try:
        with TestClient(create_app(settings)) as client:
            r = client.post(f"/api/v1/wings/{wid}/flutter", json={"design": DESIGN, "store": False})
            assert r.status_code == 200, (r.text, worker.log_tail())
            over_http = r.json()
            vector = client.post(f"/api/v1/wings/{wid}/flutter",
                                 json={"design": list(DESIGN.values()), "store": True})
            assert vector.status_code == 200, vector.text
    finally:
        worker.stop()
    _assert_same(from_cli, in_process)
    _assert_same(over_http, in_process)
    _assert_same(vector.json(), in_process)
    # the speeds are labelled: v_flutter_m_s is the true airspeed (= M a_ref on the constant-speed sweep)
    for r in in_process["results"]:
        assert r["flutter_found"]
        assert r["v_flutter_m_s"] == r["v_true_m_s"] == pytest.approx(r["mach"] * r["a_ref_m_s"], rel=1e-12)
        assert r["v_eas_m_s"] == pytest.approx(math.sqrt(2.0 * r["q_flutter_pa"] / 1.225), rel=1e-3)
        assert r["altitude_ref_m"] == 10_000.0 and r["rho_ref_kg_m3"] == pytest.approx(0.41351, rel=1e-4)
