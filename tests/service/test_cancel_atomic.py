"""Cancel is atomic with the stored result: a job that ends cancelled stores no model, a stored model belongs to a
succeeded job (romams.jobs.store_and_finish), on SQLite and (``services``) on PostgreSQL.

No worker process: the worker's training task is called in this process on the test's store, so that the cancel
lands exactly between the end of the solver (a real, small DLM training) and the storing of the ROM.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from fast_settings import RFA_FAST
from fastapi.testclient import TestClient

from api.app import create_app
from romams.persistence import JobStatus

from .conftest import BACKENDS, SentTasks, backend_settings
from .test_bad_input import problem

_TRAINED: dict = {}


@pytest.fixture(params=BACKENDS)
def trainer(request, tmp_path, monkeypatch):
    """API on a fresh store with a stored, active basis (2 shapes), and the worker's training task running in this
    process on that store; ``hook`` runs after the solver returned and before the task stores the ROM."""
    import worker.context
    import worker.tasks
    from romams_core.basis import build_basis
    from romams_core.mesh import standard_mesh
    from romams_core.wing import template
    from worker.cache import LruCache

    settings = backend_settings(request, tmp_path)
    sent = SentTasks()
    app = create_app(settings, celery=sent, sweeper=False)
    store = app.state.service.store
    monkeypatch.setattr(worker.context, "_STORE", [store])
    monkeypatch.setattr(worker.context, "OBJECTS", LruCache(8))
    real_train = worker.tasks.train_model
    hooks: list = []

    def train_then_hook(mesh, shapes, mach, ident, what, progress=None):
        key = (round(float(mach), 6), json.dumps(ident, sort_keys=True))
        if key not in _TRAINED:  # the solver runs once per module (a few seconds); later jobs reuse its model
            _TRAINED[key] = real_train(mesh, shapes, mach, ident, what, progress)
        for hook in hooks:
            hook()
        return _TRAINED[key]

    monkeypatch.setattr(worker.tasks, "train_model", train_then_hook)
    with TestClient(app) as c:
        wid = c.post("/api/v1/wings", json={"template": "cropped-delta"}).json()["id"]
        n = standard_mesh(template("cropped-delta").planform).n_nodes
        snaps = np.linalg.qr(np.random.default_rng(0).standard_normal((n, 2)))[0]
        bid = store.bases.save(wid, build_basis(snaps, n_modes=2), {"samples": 2, "modes": 2})
        assert c.put(f"/api/v1/wings/{wid}/active-basis", json={"basis_id": bid}).status_code == 200
        yield c, wid, sent, hooks, worker.tasks.training_job


def test_cancel_at_the_end_of_a_training_stores_no_model_and_resubmitting_trains_anew(trainer):
    c, wid, sent, hooks, training_job = trainer
    request = {"mach": 0.5, "options": RFA_FAST}
    r = c.post(f"/api/v1/wings/{wid}/roms", json=request)
    assert r.status_code == 202, r.text
    first = r.json()["job_id"]
    assert sent.sent[-1] == ("romams.training.rom", [first], first)
    # the solver has finished; the cancel lands before the model is stored
    hooks.append(lambda: c.post(f"/api/v1/jobs/{first}/cancel").raise_for_status())
    training_job(first)
    job = c.get(f"/api/v1/jobs/{first}").json()
    assert job["status"] == JobStatus.CANCELLED and job["result"] is None, job
    assert c.get(f"/api/v1/wings/{wid}/roms").json() == []
    assert c.get(f"/api/v1/wings/{wid}").json()["trained_machs"] == []

    hooks.clear()
    r = c.post(f"/api/v1/wings/{wid}/roms", json=request)  # not "existing": a new job trains it
    assert r.status_code == 202 and r.json()["existing"] is False, r.text
    second = r.json()["job_id"]
    assert second != first
    training_job(second)
    job = c.get(f"/api/v1/jobs/{second}").json()
    assert job["status"] == JobStatus.SUCCEEDED, job
    roms = c.get(f"/api/v1/wings/{wid}/roms").json()
    assert [(x["id"], x["job_id"], x["mach"]) for x in roms] == [(job["result"]["rom_id"], second, 0.5)]
    problem(c.post(f"/api/v1/jobs/{second}/cancel"), 409, "job_id")  # too late: the model stays with its job
    assert len(c.get(f"/api/v1/wings/{wid}/roms").json()) == 1
    again = c.post(f"/api/v1/wings/{wid}/roms", json=request)
    assert again.status_code == 200 and again.json()["rom_id"] == roms[0]["id"]


def test_store_and_finish_rolls_back_unless_the_job_is_active(trainer):
    """The guard itself: the rows written by ``save`` are committed with the job's success, or not at all."""
    from romams.jobs import Cancelled, store_and_finish

    c, wid, _, _, _ = trainer
    store = c.app.state.service.store
    bid = c.get(f"/api/v1/wings/{wid}").json()["active_basis_id"]
    basis = store.bases.load(bid)
    n_bases = len(store.bases.of_wing(wid))
    for final in (JobStatus.CANCELLED, JobStatus.SUCCEEDED, JobStatus.FAILED):
        job = store.jobs.create("basis", {}, wing_id=wid)
        store.jobs.finish(job, final)
        with pytest.raises(Cancelled):
            store_and_finish(store, job, lambda uow: {"basis_id": uow.bases.save(wid, basis, {"samples": 2})})
        assert len(store.bases.of_wing(wid)) == n_bases and store.jobs.get(job)["status"] == final
    job = store.jobs.create("basis", {}, wing_id=wid)
    out = store_and_finish(store, job, lambda uow: {"basis_id": uow.bases.save(wid, basis, {"samples": 2})})
    assert store.jobs.get(job)["status"] == JobStatus.SUCCEEDED and store.jobs.get(job)["result"] == out
    assert len(store.bases.of_wing(wid)) == n_bases + 1
