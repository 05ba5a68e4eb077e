"""End-to-end API tests on the embedded configuration: SQLite database, SQLite broker, real worker subprocess.

One service (conftest.sqlite_service, shared with test_runs.py): a cropped-delta wing, a small basis (6 LHS
samples x 3 modes) and dlm ROMs at two Mach numbers, trained by a real Celery worker; then flutter evaluations,
batches, cancellation, worker crashes and bad input for every endpoint.
"""

from __future__ import annotations

import math
import os
import signal
import time

import numpy as np
import pytest
from fast_settings import DLM_FAST

from .conftest import SQLITE_MACHS, WorkerProcess, wait_job

MACHS = SQLITE_MACHS
DESIGN = {"x1": 0.3, "x2": 0.4, "x3": 0.7, "x4": 0.05, "x5": 1.0, "x6": 1.0, "x7": 0.8}


@pytest.fixture(scope="module")
def svc(sqlite_service):
    """The embedded service of tests/service (conftest.sqlite_service), shared with test_runs.py."""
    return sqlite_service


def test_basis_job_progress_timestamps_and_mac_table(svc):
    job = svc.basis_job
    assert job["progress"] == pytest.approx(1.0, abs=1e-12) and job["error"] is None
    assert job["created_at"] <= job["started_at"] <= job["finished_at"]
    bases = svc.client.get(f"/api/v1/wings/{svc.wing_id}/bases").json()
    assert len(bases) == 1 and bases[0]["id"] == job["result"]["basis_id"]
    b = bases[0]
    assert 1 <= b["n_basis"] <= 12 and b["summary"]["min_mac"] >= 0.98
    assert np.array(b["mac_by_sample"]).shape == (6, 3)
    assert min(min(r) for r in b["mac_by_sample"]) == pytest.approx(b["summary"]["min_mac"], abs=1e-12)
    kids = svc.client.get("/api/v1/jobs", params={"include_children": True, "kind": "basis-chunk"}).json()
    assert {k["parent_id"] for k in kids} == {job["id"]} and all(k["status"] == "succeeded" for k in kids)
    png = svc.client.get(f"/api/v1/bases/{b['id']}/shapes.png")
    assert png.status_code == 200 and png.content[:8] == b"\x89PNG\r\n\x1a\n"
    svg = svc.client.get(f"/api/v1/bases/{b['id']}/mac.svg")
    assert svg.status_code == 200 and b"<svg" in svg.content[:500]


def test_training_jobs_store_roms_and_resubmission_returns_existing(svc):
    roms = svc.client.get(f"/api/v1/wings/{svc.wing_id}/roms").json()
    assert sorted(r["mach"] for r in roms) == MACHS
    for r in roms:
        assert r["solver"] == "dlm" and r["params"]["na"] == 0 and r["params"]["nb"] == 0  # the default solver
        assert max(r["summary"]["validation_nrmse"]) < 0.02  # the trainer's tolerance
    again = svc.client.post(f"/api/v1/wings/{svc.wing_id}/roms", json={"machs": MACHS, "options": DLM_FAST})
    assert again.status_code == 200
    items = again.json()["items"]
    assert all(i["existing"] for i in items)
    assert sorted(i["rom_id"] for i in items) == sorted(r["id"] for r in roms)
    assert sorted(again.json()["job_ids"]) == sorted(j["id"] for j in svc.train_jobs)
    wing = svc.client.get(f"/api/v1/wings/{svc.wing_id}").json()
    assert wing["trained_machs"] == MACHS and [v["name"] for v in wing["design_variables"]][:2] == ["x1", "x2"]


def _direct(svc, design):
    """The same evaluation done in this process straight from the core (reference for the service)."""
    from romams.persistence import open_store
    from romams_core.evaluate import evaluate_structure
    from romams_core.structure.modal import modal_analysis

    store = open_store(svc.settings)
    with store.unit_of_work() as uow:
        _, wing = uow.wings.find(svc.wing_id)
        bid = uow.wings.active_basis(svc.wing_id)
        basis = uow.bases.load(bid)
        roms = {r["mach"]: uow.roms.load(r["id"]) for r in uow.roms.of_wing(svc.wing_id, bid)}
    modal = modal_analysis(wing, design=wing.design_vector(design), n_modes=basis.n_modes)
    return evaluate_structure(modal, basis.shapes, roms, mac_threshold=basis.mac_threshold,
                              zeta=wing.modal_damping or None)  # the service applies the wing's damping


def test_single_flutter_evaluation_matches_the_core(svc):
    r = svc.client.post(f"/api/v1/wings/{svc.wing_id}/flutter", json={"design": DESIGN})
    assert r.status_code == 200, r.text
    out = r.json()
    ref = _direct(svc, DESIGN)
    assert out["mass_kg"] == pytest.approx(ref.mass_kg, rel=1e-9)
    np.testing.assert_allclose(out["frequencies_hz"], ref.frequencies_hz, rtol=1e-6)
    np.testing.assert_allclose(out["mac"], ref.mac, rtol=1e-6)
    assert [x["mach"] for x in out["results"]] == MACHS
    for got, want in zip(out["results"], ref.flutter, strict=True):
        assert want.v_flutter_m_s is not None and got["v_flutter_m_s"] == pytest.approx(want.v_flutter_m_s, rel=1e-5)
        assert got["omega_flutter_rad_s"] == pytest.approx(want.omega_flutter_rad_s, rel=1e-5)
        assert got["q_flutter_pa"] == pytest.approx(want.q_flutter_pa, rel=1e-5)
        assert got["flutter_mode"] == want.flutter_mode and got["sdoff"] == want.sdoff
        assert got["safe_altitude_m"] is not None and 0.0 <= got["safe_altitude_m"] <= 20_000.0
    assert isinstance(out["envelope_ok"], bool) and out["evaluation_id"] > 0
    # the same design as an ordered vector is the same structure: answered from the stored evaluation
    vec = [DESIGN[f"x{i}"] for i in range(1, 8)]
    again = svc.client.post(f"/api/v1/wings/{svc.wing_id}/flutter", json={"design": vec})
    assert again.status_code == 200 and again.json()["evaluation_id"] == out["evaluation_id"]
    assert again.json()["cached"] is True
    # one Mach only
    one = svc.client.post(f"/api/v1/wings/{svc.wing_id}/flutter", json={"design": DESIGN, "machs": [0.87]}).json()
    assert [x["mach"] for x in one["results"]] == [0.87]
    assert one["results"][0]["v_flutter_m_s"] == pytest.approx(out["results"][1]["v_flutter_m_s"], rel=1e-6)


def test_rom_pms_reference_through_the_api(svc):
    """method rom-pms trains on the design's own modes (a training job) and lands near ROM-AMS."""
    ams = svc.client.post(f"/api/v1/wings/{svc.wing_id}/flutter", json={"design": DESIGN}).json()
    r = svc.client.post(f"/api/v1/wings/{svc.wing_id}/flutter", json={"design": DESIGN, "method": "rom-pms"})
    assert r.status_code == 202, r.text
    job = wait_job(svc.client, r.json()["job_id"])
    assert job["status"] == "succeeded", (job, svc.worker.log_tail())
    assert job["kind"] == "flutter-pms"
    pms = job["result"]
    assert pms["method"] == "rom-pms" and min(pms["mac"]) > 0.999999  # own modes: exact fit
    assert pms["mass_kg"] == pytest.approx(ams["mass_kg"], rel=1e-12)
    for a, p in zip(ams["results"], pms["results"], strict=True):
        assert a["mach"] == p["mach"]
        # this fixture's basis is small (6 samples x 3 modes, MAC 0.98): ROM-AMS within a few percent
        assert a["v_flutter_m_s"] == pytest.approx(p["v_flutter_m_s"], rel=0.05)
    ev = svc.client.get(f"/api/v1/evaluations/{pms['evaluation_id']}")
    assert ev.status_code == 200 and ev.json()["method"] == "rom-pms"
    bad = svc.client.post(f"/api/v1/wings/{svc.wing_id}/flutter/batch", json={"designs": [DESIGN], "method": "rom-pms"})
    assert bad.status_code == 422 and "method" in bad.text


def test_baseline_evaluation_and_envelope_plots(svc):
    r = svc.client.post(f"/api/v1/wings/{svc.wing_id}/flutter", json={})
    assert r.status_code == 200, r.text
    base = r.json()
    # the baseline compared with itself (the worker reuses its one baseline eigensolve): zero margin, envelope ok
    assert base["envelope_margin_m"] == [0.0, 0.0] and base["envelope_ok"] is True
    eid = base["evaluation_id"]
    vg = svc.client.get(f"/api/v1/evaluations/{eid}/vg").json()
    assert [m["mach"] for m in vg["machs"]] == MACHS
    for m in vg["machs"]:
        v, g, w = np.array(m["v_m_s"]), np.array(m["g"], dtype=float), np.array(m["omega_rad_s"], dtype=float)
        assert v.ndim == 1 and g.shape == w.shape == (v.size, 3) and np.all(np.diff(v) > 0)
    for params, fmt, magic in (({"kind": "vg"}, "png", b"\x89PNG"), ({"kind": "vg", "mach": 0.87}, "svg", b"<?xml"),
                               ({"kind": "envelope"}, "svg", b"<?xml")):
        p = svc.client.get(f"/api/v1/evaluations/{eid}/plot.{fmt}", params=params)
        assert p.status_code == 200 and p.content.startswith(magic), p.text[:200]
    bad = svc.client.get(f"/api/v1/evaluations/{eid}/plot.png", params={"kind": "vg", "mach": 0.5})
    assert bad.status_code == 422 and bad.json()["field"] == "mach"
    listed = svc.client.get("/api/v1/evaluations", params={"wing_id": svc.wing_id}).json()
    assert eid in [e["id"] for e in listed]


def test_batch_results_in_order_and_equal_to_single_evaluations(svc):
    from romams_core.basis import sample_designs
    from romams_core.wing import template

    designs = sample_designs(template("cropped-delta"), 3, seed=11).tolist()
    r = svc.client.post(f"/api/v1/wings/{svc.wing_id}/flutter/batch", json={"designs": designs})
    assert r.status_code == 200, r.text
    results = r.json()["results"]
    assert len(results) == 3
    for d, got in zip(designs, results, strict=True):
        single = svc.client.post(f"/api/v1/wings/{svc.wing_id}/flutter", json={"design": d}).json()  # computed anew
        assert got["mass_kg"] == pytest.approx(single["mass_kg"], rel=1e-9)
        for a, b in zip(got["results"], single["results"], strict=True):
            if b["v_flutter_m_s"] is None:
                assert a["v_flutter_m_s"] is None
            else:
                assert a["v_flutter_m_s"] == pytest.approx(b["v_flutter_m_s"], rel=1e-5)


def test_large_batch_returns_a_job(svc):
    from romams_core.basis import sample_designs
    from romams_core.wing import template

    designs = sample_designs(template("cropped-delta"), 6, seed=12).tolist()  # > batch_sync_max = 4
    r = svc.client.post(f"/api/v1/wings/{svc.wing_id}/flutter/batch", json={"designs": designs})
    assert r.status_code == 202 and r.headers["location"] == f"/api/v1/jobs/{r.json()['job_id']}"
    job = wait_job(svc.client, r.json()["job_id"])
    assert job["status"] == "succeeded" and job["kind"] == "flutter-batch"
    assert len(job["result"]["results"]) == 6
    assert all(math.isfinite(x["mass_kg"]) for x in job["result"]["results"])


def test_external_modes_give_the_same_flutter_point(svc):
    from romams.persistence import open_store
    from romams_core.structure.modal import modal_analysis

    _, wing = open_store(svc.settings).wings.find(svc.wing_id)
    modal = modal_analysis(wing, design=wing.design_vector(DESIGN), n_modes=3)
    nodes = np.column_stack([modal.fe_xy, np.zeros(len(modal.fe_xy))])
    body = {"modes": {"nodes": nodes.tolist(), "shapes": modal.fe_shapes.T.tolist(),
                      "frequencies_hz": modal.frequencies_hz.tolist()}}
    r = svc.client.post(f"/api/v1/wings/{svc.wing_id}/flutter", json=body)
    assert r.status_code == 200, r.text
    ext = r.json()
    ref = svc.client.post(f"/api/v1/wings/{svc.wing_id}/flutter", json={"design": DESIGN}).json()
    assert ext["mass_kg"] is None  # not given with the modes
    assert min(ext["mac"]) >= 0.98
    for a, b in zip(ext["results"], ref["results"], strict=True):  # FE -> standard mesh re-mapping: within 2 %
        assert a["v_flutter_m_s"] == pytest.approx(b["v_flutter_m_s"], rel=0.02)


def test_dashboard_lists_jobs_wings_bases_roms(svc):
    html = svc.client.get("/dashboard")
    assert html.status_code == 200 and html.headers["content-type"].startswith("text/html")
    page = html.text
    assert "cd-test" in page and svc.basis_job["id"] in page and "worst MAC" in page
    assert "0.790" in page and "0.870" in page and "/static/dashboard.js" in page
    js = svc.client.get("/static/dashboard.js")
    assert js.status_code == 200 and "setInterval(poll, 1000)" in js.text


def test_cancel_a_running_training_job(svc):
    r = svc.client.post(f"/api/v1/wings/{svc.wing_id}/roms", json={"mach": 0.6, "solver": "uvlm",
                                                                     "options": {"n_steps": 30000}})
    assert r.status_code == 202
    jid = r.json()["job_id"]
    wait_job(svc.client, jid, 120, until=("running", "succeeded", "failed"))
    c = svc.client.post(f"/api/v1/jobs/{jid}/cancel")
    assert c.status_code == 200 and c.json()["status"] == "cancelled"
    assert svc.client.post(f"/api/v1/jobs/{jid}/cancel").status_code == 409
    time.sleep(2.0)  # the task notices at its next progress step and stops
    assert svc.client.get(f"/api/v1/jobs/{jid}").json()["status"] == "cancelled"
    assert 0.6 not in [x["mach"] for x in svc.client.get(f"/api/v1/wings/{svc.wing_id}/roms").json()]


def test_killed_pool_process_job_is_redelivered(svc):
    r = svc.client.post(f"/api/v1/wings/{svc.wing_id}/roms", json={"mach": 0.7, "solver": "uvlm",
                                                                     "options": {"n_steps": 12000}})
    jid = r.json()["job_id"]
    job = wait_job(svc.client, jid, 120, until=("running", "succeeded", "failed"))
    assert job["status"] == "running"
    pid = int(job["worker"].rsplit(":", 1)[1])
    assert pid in svc.worker.pool_pids(), (job, svc.worker.log_tail())
    os.kill(pid, signal.SIGKILL)  # the process running the task dies (OOM killer, segfault...)
    job = wait_job(svc.client, jid, 240)
    assert job["status"] == "succeeded", (job, svc.worker.log_tail())
    assert job["deliveries"] >= 2  # it ran again after the crash
    assert 0.7 in [x["mach"] for x in svc.client.get(f"/api/v1/wings/{svc.wing_id}/roms").json()]


def test_killed_worker_machine_job_is_resent_by_the_sweeper(svc):
    r = svc.client.post(f"/api/v1/wings/{svc.wing_id}/roms", json={"mach": 0.75, "solver": "uvlm",
                                                                     "options": {"n_steps": 12000}})
    jid = r.json()["job_id"]
    job = wait_job(svc.client, jid, 120, until=("running", "succeeded", "failed"))
    assert job["status"] == "running"
    svc.worker.kill_all()  # worker and pool gone at once: the broker message is lost with them
    svc.worker = WorkerProcess(svc.env, svc.data / "worker2.log")
    job = wait_job(svc.client, jid, 240)
    assert job["status"] == "succeeded", (job, svc.worker.log_tail())
    assert job["deliveries"] >= 2


def test_flutter_bad_input_is_rejected_and_stores_nothing(svc):
    from .test_bad_input import problem

    c, url = svc.client, f"/api/v1/wings/{svc.wing_id}/flutter"
    n_eval = len(c.get("/api/v1/evaluations", params={"limit": 500}).json())
    n_jobs = len(c.get("/api/v1/jobs", params={"limit": 1000, "include_children": True}).json())
    problem(c.post(url, json={"design": DESIGN, "machs": [0.5]}), 422, "machs[0]", "not trained")
    problem(c.post(url, json={"design": DESIGN, "machs": [0.79, 0.79]}), 422, "machs", "duplicates")
    problem(c.post(url, json={"design": {**DESIGN, "x1": 5.0}}), 422, "design.x1", "outside its bounds")
    problem(c.post(url, json={"design": {**DESIGN, "x9": 1.0}}), 422, "design", "unknown variable")
    problem(c.post(url, json={"design": [0.3, 0.4]}), 422, "design", "expected 7 values")
    problem(c.post(url, content=b'{"design": [NaN, 0.4, 0.7, 0.05, 1, 1, 0.8]}',
                   headers={"content-type": "application/json"}), 422, "design[0]", "finite")
    problem(c.post(url, content=b'{"design": {"x1": Infinity}}', headers={"content-type": "application/json"}),
            422, "design.x1", "finite")
    problem(c.post(url, json={"design": DESIGN, "modes_id": 1}), 422, "body", "at most one")
    problem(c.post(url, json={"modes_id": 9999}), 404, "modes_id")
    problem(c.post(url, json={"design": DESIGN, "method": "dlm"}), 422, "method")
    nodes = [[x, y, 0.0] for x in (0.0, 0.2, 0.4) for y in (0.0, 0.3, 0.6)]
    problem(c.post(url, json={"modes": {"nodes": nodes, "shapes": [[0.0] * 5], "frequencies_hz": [10.0]}}),
            422, "modes.shapes")
    far = [[1000 * x, 1000 * y, 0.0] for x, y, _ in nodes]  # millimetres instead of metres
    problem(c.post(url, json={"modes": {"nodes": far, "shapes": [[1.0] * 9], "frequencies_hz": [10.0]}}),
            422, "modes.nodes", "planform")
    batch = f"{url}/batch"
    problem(c.post(batch, json={"designs": []}), 422, "designs")
    problem(c.post(batch, json={"designs": [DESIGN, {**DESIGN, "x6": 0.1}]}), 422, "designs[1].x6", "bounds")
    problem(c.post(batch, json={"designs": [DESIGN] * (svc.settings.batch_max + 1)}), 413, "designs", "at most")
    assert len(c.get("/api/v1/evaluations", params={"limit": 500}).json()) == n_eval
    assert len(c.get("/api/v1/jobs", params={"limit": 1000, "include_children": True}).json()) == n_jobs
    assert c.post(url, json={"design": DESIGN}).status_code == 200  # still serving
