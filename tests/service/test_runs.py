"""Runs (studies): the API (201/404/422 problem+json), every design of a tagged batch stored compactly as an
evaluation of its run (the shared embedded service: real worker subprocess, SQLite), V-g data kept only on request
or for new best designs, job filters, the traceback and progress history of jobs, the run and job pages; the
repository's one-statement chunk insert on SQLite and PostgreSQL."""

from __future__ import annotations

import re

import numpy as np
import pytest

from .conftest import BACKENDS, SQLITE_MACHS, backend_settings, wait_job

MACHS = SQLITE_MACHS
#: stored payload of one design of a 7-variable, 2-Mach run (bytes): the design vector and the flutter rows
BYTES_PER_DESIGN_MAX = 400


@pytest.fixture(scope="module")
def svc(sqlite_service):
    """The embedded service with a real worker (conftest.sqlite_service, shared with test_api_sqlite.py)."""
    return sqlite_service


def _designs(n: int, seed: int) -> list[list[float]]:
    """``n`` LHS designs of the cropped delta."""
    from romams_core.basis import sample_designs
    from romams_core.wing import template

    return sample_designs(template("cropped-delta"), n, seed=seed).tolist()


def _problem(r, status: int, field: str) -> None:
    """``r`` is an RFC 9457 problem with this status and field."""
    assert r.status_code == status, r.text
    assert r.headers["content-type"].startswith("application/problem+json")
    assert r.json()["field"] == field, r.json()


def _batch(svc, designs: list, **extra) -> list[dict]:
    """Results of a batch (waiting for its job when it is answered with 202)."""
    # the Machs named: test_api_sqlite.py, sharing the service, trains ROMs at more Machs (any test order)
    r = svc.client.post(f"/api/v1/wings/{svc.wing_id}/flutter/batch",
                        json={"designs": designs, "machs": MACHS, **extra})
    assert r.status_code in (200, 202), r.text
    if r.status_code == 202:
        job = wait_job(svc.client, r.json()["job_id"])
        assert job["status"] == "succeeded", (job, svc.worker.log_tail())
        return job["result"]["results"]
    return r.json()["results"]


def test_create_and_read_runs(svc):
    c = svc.client
    r = c.post("/api/v1/runs", json={"name": "DE study", "wing": "cd-test", "mu_kg": 5.0})
    assert r.status_code == 201, r.text
    run = r.json()
    assert r.headers["location"] == f"/api/v1/runs/{run['id']}"
    assert run["name"] == "DE study" and run["wing_id"] == svc.wing_id and run["status"] == "empty"
    assert run["settings"] == {"mu_kg": 5.0, "mac_threshold": 0.98, "envelope_tol_m": 0.01, "penalty": "binary"}
    assert run["n_evaluations"] == 0 and run["best"] is None
    assert c.get(f"/api/v1/runs/{run['id']}").json()["id"] == run["id"]
    assert run["id"] in [x["id"] for x in c.get("/api/v1/runs").json()]
    _problem(c.get("/api/v1/runs/999999"), 404, "run_id")
    _problem(c.get("/api/v1/runs/999999/evaluations"), 404, "run_id")
    _problem(c.post("/api/v1/runs", json={"name": ""}), 422, "name")
    _problem(c.post("/api/v1/runs", json={"name": 5}), 422, "name")
    _problem(c.post("/api/v1/runs", json={"name": "x" * 201}), 422, "name")
    _problem(c.post("/api/v1/runs", json={}), 422, "name")
    _problem(c.post("/api/v1/runs", json={"name": "a", "mu_kg": -1.0}), 422, "mu_kg")
    _problem(c.post("/api/v1/runs", json={"name": "a", "penalty": "steep"}), 422, "penalty")
    _problem(c.post("/api/v1/runs", json={"name": "a", "wing": "no-such-wing"}), 404, "wing")
    url = f"/api/v1/wings/{svc.wing_id}/flutter/batch"
    _problem(c.post(url, json={"designs": _designs(1, 1), "run_id": 999999}), 404, "run_id")
    _problem(c.post(url, json={"designs": _designs(1, 1), "keep_vg": True}), 422, "keep_vg")


def _feasible(r: dict, mu: float) -> tuple[bool, float]:
    """The client's rule (FlutterProblem, binary penalty): (feasible, objective)."""
    env_ok = r["envelope_ok"] is None or r["envelope_ok"] or min(r["envelope_margin_m"]) >= -0.01
    ok = bool(env_ok and not r["sdoff"] and min(r["mac"]) >= 0.98)
    return ok, r["mass_kg"] + (0.0 if ok else mu)


def test_graded_penalty_factor():
    """The run's graded C (romams.services.runs.penalty_factor, the client's FlutterProblem(penalty="graded"))."""
    from romams.services.runs import penalty_factor, run_settings

    graded, binary = run_settings({"penalty": "graded"}), run_settings(None)
    summary = {"envelope_margin_m": [-1500.0, 200.0, -500.0], "mac": [0.999, 0.97],
               "results": [{"sdoff": True}, {"sdoff": False}, {"sdoff": True}]}
    # envelope excess 2 km (failing envelope), MAC deficit 0.01 / 0.02, two SDOFF Machs
    assert penalty_factor(summary, graded, ok=False, env_ok=False) == pytest.approx(1 + 2.0 + 0.5 + 2)
    assert penalty_factor(summary, graded, ok=False, env_ok=True) == pytest.approx(1 + 0.5 + 2)
    assert penalty_factor(summary, binary, ok=False, env_ok=False) == 1.0
    assert penalty_factor(summary, graded, ok=True, env_ok=True) == 0.0


def test_every_design_of_a_run_is_stored_compactly(svc):
    c = svc.client
    run_id = c.post("/api/v1/runs", json={"name": "stored", "mu_kg": 7.0}).json()["id"]
    designs = _designs(6, 21) + _designs(3, 22)
    results = _batch(svc, designs[:6], run_id=run_id) + _batch(svc, designs[6:], run_id=run_id)  # 202 and 200 paths
    out = c.get(f"/api/v1/runs/{run_id}/evaluations").json()
    rows = out["evaluations"]
    assert len(rows) == 9 and out["last_id"] == rows[-1]["id"]
    by_x = {tuple(r["x"]): r for r in rows}
    for d, res in zip(designs, results, strict=True):
        row = by_x[tuple(d)]  # the design vector exactly as sent
        ok, objective = _feasible(res, 7.0)
        assert row["feasible"] == ok and row["mass_kg"] == pytest.approx(res["mass_kg"], rel=1e-12)
        assert row["objective"] == pytest.approx(objective, rel=1e-12)
        assert row["min_mac"] == pytest.approx(min(res["mac"]), rel=1e-7)
        assert [f[0] for f in row["flutter"]] == MACHS
        for (_, vf, fhz, mode, alt, bench), p, margin in zip(row["flutter"], res["results"], res["envelope_margin_m"],
                                                             strict=True):
            assert mode == p["flutter_mode"] and vf == pytest.approx(p["v_eas_m_s"], rel=1e-5)
            assert fhz == pytest.approx(p["frequency_hz"], rel=1e-5)
            assert alt == pytest.approx(p["safe_altitude_m"], rel=1e-5)
            assert bench == pytest.approx(alt + margin, rel=1e-5)
    s = c.get(f"/api/v1/runs/{run_id}").json()
    assert s["n_evaluations"] == 9 and s["n_feasible"] + s["n_infeasible"] == 9 and s["n_failed"] == 0
    assert s["n_feasible"] == sum(r["feasible"] for r in rows) and s["status"] == "idle"
    feas = [r for r in rows if r["feasible"]]
    best = min(feas or rows, key=lambda r: r["objective"])
    assert s["best"]["id"] == best["id"] and s["best_objective"] == best["objective"]
    # V-g data only for new best designs: at most one per chunk (3 + 3 chunks), and the best design has them
    kept = [r for r in rows if r["evaluation_id"] is not None]
    assert len(kept) == s["n_with_vg"] <= 6 and (not feas or best["evaluation_id"] is not None)
    if feas:
        vg = c.get(f"/api/v1/evaluations/{best['evaluation_id']}/vg").json()
        assert vg["machs"][0]["mach"] == MACHS[0] and len(vg["machs"][0]["g"]) > 0  # the V-g branches
        assert vg["machs"][0]["omega_flutter_rad_s"] == pytest.approx(2 * np.pi * best["flutter"][0][2], rel=1e-5)
    assert 0 < s["bytes_per_design"] <= BYTES_PER_DESIGN_MAX, s["bytes_per_design"]
    # incremental polling and the job filters: the batches are listed under their run
    assert len(c.get(f"/api/v1/runs/{run_id}/evaluations", params={"after_id": rows[4]["id"]}).json()
               ["evaluations"]) == 4
    jobs = c.get("/api/v1/jobs", params={"run_id": run_id})
    assert jobs.headers["x-total-count"] == "2" and {j["run_id"] for j in jobs.json()} == {run_id}
    assert all(j["run_id"] is None for j in c.get("/api/v1/jobs", params={"include_runs": False}).json())
    assert c.get("/api/v1/jobs", params={"wing_id": 999999}).json() == []
    page = c.get(f"/dashboard/runs/{run_id}")
    assert page.status_code == 200 and 'id="history"' in page.text and 'id="envelope"' in page.text
    scripts = [f'<script src="/static/{n}.js">' for n in ("common", "plots", "run")]
    assert re.findall(r"<script[^>]*>", page.text) == scripts  # no inline script (the CSP allows none)
    assert c.get("/dashboard/runs/999999").status_code == 404 and c.get("/dashboard/runs").status_code == 200


def test_a_best_design_from_the_result_cache_keeps_its_vg(svc):
    """The worker's result cache keeps summaries only: a run's new best design answered from it is evaluated again
    so that its V-g data are kept (the same designs in fresh runs, so that they come from a worker's cache)."""
    c = svc.client
    designs = _designs(3, 41)
    _batch(svc, designs)  # evaluated (and cached) outside any run
    for k in range(3):  # each chunk lands on one of the worker's processes: repeat so that the cache serves them
        run_id = c.post("/api/v1/runs", json={"name": f"cached {k}"}).json()["id"]
        _batch(svc, designs, run_id=run_id)
        s = c.get(f"/api/v1/runs/{run_id}").json()
        assert s["best"] is not None and s["best"]["feasible"], s  # these designs have a feasible best
        assert s["best"]["evaluation_id"] is not None, s
        vg = c.get(f"/api/v1/evaluations/{s['best']['evaluation_id']}/vg").json()
        assert len(vg["machs"][0]["g"]) > 0


def test_keep_vg_keeps_every_design(svc):
    c = svc.client
    run_id = c.post("/api/v1/runs", json={"name": "vg"}).json()["id"]
    _batch(svc, _designs(3, 31), run_id=run_id, keep_vg=True)
    rows = c.get(f"/api/v1/runs/{run_id}/evaluations").json()["evaluations"]
    assert len(rows) == 3 and all(r["evaluation_id"] is not None for r in rows)
    ev = c.get(f"/api/v1/evaluations/{rows[0]['evaluation_id']}").json()
    assert ev["request"]["run_id"] == run_id and ev["request"]["design"] == rows[0]["x"]
    from sqlalchemy import text

    engine = svc.app.state.service.store.engine
    with engine.connect() as conn:  # what keeping V-g data costs: one evaluation row per design
        vg_bytes = conn.execute(text("SELECT length(blob) + length(summary) FROM evaluations WHERE id = :i"),
                                {"i": rows[0]["evaluation_id"]}).scalar_one()
    print(f"V-g evaluation of one design at {len(MACHS)} Machs: {vg_bytes} bytes")
    assert vg_bytes > 10 * BYTES_PER_DESIGN_MAX  # why they are kept only on request or for a new best design


def test_failed_job_keeps_its_traceback(svc):
    r = svc.client.post(f"/api/v1/wings/{svc.wing_id}/roms", json={"mach": 0.5, "solver": "uvlm",
                                                                     "options": {"k_max": -1.0}})
    assert r.status_code == 202, r.text
    job = wait_job(svc.client, r.json()["job_id"])
    assert job["status"] == "failed" and "k_max" in job["error"], job
    assert job["traceback"].startswith("Traceback (most recent call last)") and "k_max" in job["traceback"]
    assert 'File "romams/jobs.py"' in job["traceback"]  # file names relative to the project: no machine path
    assert job["events"] == [] or all(len(e) == 3 for e in job["events"])
    failed = svc.client.get("/api/v1/jobs", params={"status": "failed", "wing_id": svc.wing_id}).json()
    assert job["id"] in [j["id"] for j in failed]
    page = svc.client.get(f"/dashboard/jobs/{job['id']}").text
    assert "Traceback (most recent call last)" in page and "k_max" in page and 'id="job-error"' in page
    assert svc.client.get("/dashboard/jobs/no-such-job").status_code == 404
    assert svc.client.get("/dashboard/jobs").status_code == 200


@pytest.fixture(params=BACKENDS)
def store(request, tmp_path):
    from romams.persistence import open_store

    return open_store(backend_settings(request, tmp_path), migrate=True)


def test_a_chunk_is_one_insert_statement(store):
    from sqlalchemy import event

    from romams.services.runs import compact_row

    run_id = store.runs.create("repo", {"mu_kg": 10.0, "mac_threshold": 0.98, "envelope_tol_m": 0.01})
    rng = np.random.default_rng(0)
    settings = store.runs.get(run_id)["settings"]
    rows = []
    for i in range(64):
        mass = 0.2 + 0.05 * rng.random()
        margin = [float(rng.normal(0, 100)), float(rng.normal(0, 100))]
        summary = {"mass_kg": mass, "mac": [0.999, 0.99, 0.985], "sdoff": False, "envelope_ok": min(margin) >= 0,
                   "envelope_margin_m": margin,
                   "results": [{"mach": m, "v_flutter_m_s": 250 + i, "frequency_hz": 20.123456789, "flutter_mode": 2,
                                "safe_altitude_m": 5000.0 + i, "sdoff": False} for m in (0.87, 0.95)]}
        rows.append(compact_row(rng.random(7).tolist(), summary, settings, "job"))
    statements: list[str] = []
    listen = lambda *a: statements.append(a[2])  # noqa: E731 - (conn, cursor, statement, ...)
    event.listen(store.engine, "before_cursor_execute", listen)
    try:
        with store.unit_of_work() as uow:
            assert uow.runs.add_evaluations(run_id, rows) == 64
    finally:
        event.remove(store.engine, "before_cursor_execute", listen)
    inserts = [s for s in statements if s.lstrip().upper().startswith("INSERT")]
    assert len(inserts) == 1 and "run_evaluations" in inserts[0]
    counts = store.runs.counts(run_id)
    assert counts["n_evaluations"] == 64 and counts["n_feasible"] == sum(r["feasible"] for r in rows)
    assert counts["payload_bytes"] / 64 <= BYTES_PER_DESIGN_MAX  # 2 Machs, 7 variables
    best = store.runs.best(run_id)
    feas = [r for r in rows if r["feasible"]]
    assert best["objective"] == pytest.approx(min(r["objective"] for r in (feas or rows)), rel=1e-12)
    assert [r["x"] for r in store.runs.evaluations(run_id, limit=3)] == [r["x"] for r in rows[:3]]


def test_progress_history_keeps_each_new_message(store):
    from romams.persistence.jobs import EVENTS_MAX

    job_id = store.jobs.create("basis", {})
    assert store.jobs.start(job_id, max_deliveries=3)[0]
    for i in range(EVENTS_MAX + 10):
        assert store.jobs.progress(job_id, i / 100, f"step {i}")
        assert store.jobs.progress(job_id, i / 100 + 0.001, f"step {i}")  # the same message: not appended again
    events = store.jobs.get(job_id)["events"]
    assert len(events) == EVENTS_MAX and [e[2] for e in events] == [f"step {i}" for i in range(10, EVENTS_MAX + 10)]
    assert events[-1][1] == pytest.approx((EVENTS_MAX + 9) / 100, abs=1e-4) and events[-1][0].endswith("Z")
    assert store.jobs.finish(job_id, "failed", error="boom", traceback="Traceback ...")
    job = store.jobs.get(job_id)
    assert job["traceback"] == "Traceback ..." and not store.jobs.progress(job_id, 1.0, "late")


def test_a_best_designs_vg_equals_its_kept_vg(svc):
    """A chunk that keeps no V-g data skips the full-spectrum checks of the curves after each crossing
    (docs/performance.md 6c); its new best design, stored with its curves, is evaluated again with them. So its
    stored V-g data equal those of the same design in a run that keeps every design's (keep_vg: every check on)."""
    c = svc.client
    designs = _designs(4, 57)  # new designs: evaluated by the chunk, not answered from the result cache
    first = c.post("/api/v1/runs", json={"name": "best vg"}).json()["id"]
    _batch(svc, designs, run_id=first)
    best = c.get(f"/api/v1/runs/{first}").json()["best"]
    assert best is not None and best["evaluation_id"] is not None
    kept = c.post("/api/v1/runs", json={"name": "all vg"}).json()["id"]
    _batch(svc, designs, run_id=kept, keep_vg=True)
    rows = c.get(f"/api/v1/runs/{kept}/evaluations").json()["evaluations"]
    same = next(r for r in rows if r["x"] == best["x"])
    a = c.get(f"/api/v1/evaluations/{best['evaluation_id']}/vg").json()["machs"]
    b = c.get(f"/api/v1/evaluations/{same['evaluation_id']}/vg").json()["machs"]
    assert len(a) == len(b) == len(MACHS)
    for ma, mb in zip(a, b, strict=True):
        assert ma["omega_flutter_rad_s"] == pytest.approx(mb["omega_flutter_rad_s"], rel=1e-12)
        np.testing.assert_allclose(np.asarray(ma["g"], float), np.asarray(mb["g"], float), rtol=0, atol=1e-12)
