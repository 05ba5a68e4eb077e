"""Celery tasks: thin wrappers that load inputs from the store, call romams_core and persist results.

Every task takes one job id; the job row (romams.persistence) carries the parameters, progress and outcome.
This module holds the training-queue tasks; the flutter evaluations are in ``worker.evaluation``.
Basis jobs fan out: the parent samples the design space and creates chunk jobs of modal analyses (spread
over the workers); the chunk that completes last claims the parent's "finalize" stage and sends the SVD
task. The first basis of a wing becomes its active basis; a later one only when activated explicitly.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from romams.jobs import BrokerUnavailable, ProgressFn, fanout_outcome, send, store_and_finish
from romams.persistence import JobStatus, UnitOfWork
from romams.pipeline import own_mode_basis
from romams.services.models import activate_first_basis
from worker.celery_app import app
from worker.context import load_basis, load_mesh, load_wing, run, settings, store, train_model


# ---- basis ---------------------------------------------------------------------------------------
def _chunks(n: int, size: int) -> list[range]:
    """Consecutive index ranges of at most ``size`` covering 0..n-1."""
    return [range(i, min(i + size, n)) for i in range(0, n, size)]


@app.task(name="romams.training.basis", acks_late=True, time_limit=settings.training_time_limit_s)
def basis_job(job_id: str) -> None:
    """Basis job: LHS sample of the design space, then chunks of modal analyses fanned out to workers."""
    from romams_core.basis import sample_designs

    def body(job: dict[str, Any], progress: ProgressFn) -> None:
        p = job["params"]
        wing = load_wing(job["wing_id"])
        s = store()
        if not wing.design_variables:  # a fixed structure (the Goland wing): its own modes are its basis
            basis = own_mode_basis(wing, int(p["modes"]))

            def save_own(uow: UnitOfWork) -> dict[str, Any]:
                bid = uow.bases.save(job["wing_id"], basis, p, job_id=job_id)
                active = activate_first_basis(uow, int(job["wing_id"]), bid)
                return {"basis_id": bid, "active": active, "n_basis": int(basis.n_basis),
                        "min_mac": float(basis.min_mac), "capped": False, "own_modes": True}

            store_and_finish(s, job_id, save_own)  # stored, activated and succeeded together, unless cancelled
            return
        designs = sample_designs(wing, int(p["samples"]), seed=int(p["seed"]))
        chunks = [{"index": idx, "designs": designs[r.start:r.stop].tolist(), "modes": int(p["modes"])}
                  for idx, r in enumerate(_chunks(len(designs), settings.basis_chunk))]
        with s.unit_of_work() as uow:  # the chunk rows are committed together, before any message is sent
            children = uow.jobs.fan_out(job_id, "basis-chunk", chunks, wing_id=job["wing_id"])
        if children is None:  # cancelled meanwhile
            return
        s.jobs.claim_stage(job_id, None, "fanout")
        progress(0.02, f"{len(designs)} samples in {len(children)} chunks of modal analyses")
        for c in children:
            if c["status"] == JobStatus.QUEUED:
                try:
                    send(app, "romams.training.basis_chunk", c["id"])
                except BrokerUnavailable:  # the chunks stay queued: the sweeper re-sends them (job_queued_resend_s)
                    break

    run(job_id, body, finish=False)


def _after_chunk(parent_id: str, finalize_task: str, lo: float, hi: float) -> None:
    """Update a fan-out parent after one of its chunks ended; the last one sends ``finalize_task``."""
    s = store()
    kids = fanout_outcome(s, parent_id)
    if kids is None:
        return
    done = sum(k["status"] == JobStatus.SUCCEEDED for k in kids)
    s.jobs.progress(parent_id, lo + (hi - lo) * done / max(len(kids), 1), f"{done}/{len(kids)} chunks done")
    if done == len(kids) and s.jobs.claim_stage(parent_id, "fanout", "finalize"):
        app.send_task(finalize_task, args=[parent_id])


@app.task(name="romams.training.basis_chunk", acks_late=True, time_limit=settings.training_time_limit_s)
def basis_chunk(job_id: str) -> None:
    """Modal analyses of one chunk of sample designs; snapshots stored as an artifact."""
    from romams_core.basis import snapshot

    def body(job: dict[str, Any], progress: ProgressFn) -> dict[str, Any]:
        wing = load_wing(job["wing_id"])
        designs = np.asarray(job["params"]["designs"], dtype=float)
        k = int(job["params"]["modes"])
        snaps = []
        for i, d in enumerate(designs):
            snaps.append(snapshot(wing, d, k))
            progress((i + 1) / len(designs), f"modal analysis {i + 1}/{len(designs)}")
        store().artifacts.save(job_id, "snapshots", np.hstack(snaps))
        return {"n_designs": len(designs)}

    run(job_id, body)
    job = store().jobs.get(job_id)
    if job and job["parent_id"] and job["status"] in (JobStatus.SUCCEEDED, JobStatus.FAILED):
        _after_chunk(job["parent_id"], "romams.training.basis_finalize", 0.05, 0.9)


@app.task(name="romams.training.basis_finalize", acks_late=True, time_limit=settings.training_time_limit_s)
def basis_finalize(job_id: str) -> None:
    """SVD of all chunk snapshots -> Basis, stored; the parent job succeeds with its summary."""
    from romams_core.basis import build_basis

    def body(job: dict[str, Any], progress: ProgressFn) -> dict[str, Any]:
        p = job["params"]
        s = store()
        with s.unit_of_work() as uow:
            kids = sorted(uow.jobs.children(job_id), key=lambda k: k["params"]["index"])
            snaps = np.hstack([uow.artifacts.load(k["id"], "snapshots") for k in kids])
        designs = np.vstack([np.asarray(k["params"]["designs"], dtype=float) for k in kids])
        wing = load_wing(job["wing_id"])
        progress(0.92, f"SVD of {snaps.shape[1]} snapshots")
        basis = build_basis(snaps, mac_threshold=float(p["mac_threshold"]), max_basis=int(p["max_basis"]),
                            n_modes=int(p["modes"]), designs=designs, design_names=list(wing.variable_names),
                            wing_name=wing.name)
        def save(uow: UnitOfWork) -> dict[str, Any]:
            bid = uow.bases.save(job["wing_id"], basis, p, job_id=job_id)
            active = activate_first_basis(uow, int(job["wing_id"]), bid)
            return {"basis_id": bid, "active": active, "n_basis": int(basis.n_basis),
                    "min_mac": float(basis.min_mac), "capped": bool(basis.capped),
                    "min_mac_by_m": basis.min_mac_by_m.tolist()}

        # stored, (if first) activated and the job succeeded in one transaction, unless it was cancelled
        return store_and_finish(s, job_id, save)

    run(job_id, body, count_delivery=False, finish=False)


# ---- training ------------------------------------------------------------------------------------
@app.task(name="romams.training.rom", acks_late=True, time_limit=settings.training_time_limit_s)
def training_job(job_id: str) -> None:
    """Train the aerodynamic ROM of one Mach number on the basis shapes and store it."""

    def body(job: dict[str, Any], progress: ProgressFn) -> dict[str, Any]:
        p = dict(job["params"])
        wing_id, basis_id = int(job["wing_id"]), int(p["basis_id"])
        basis = load_basis(basis_id)
        mesh = load_mesh(wing_id)
        progress(0.0, f"training M = {p['mach']:.3f} with {p['solver']} on {basis.n_basis} basis shapes")
        rom = train_model(mesh, basis.shapes, float(p["mach"]), p["identity"], "training", progress)
        nrmse = np.atleast_1d(np.asarray(getattr(rom, "validation_nrmse", np.nan), dtype=float))

        def save(uow: UnitOfWork) -> dict[str, Any]:
            rid = uow.roms.save(wing_id, basis_id, rom, p["identity"], job_id=job_id)
            return {"rom_id": rid, "mach": float(p["mach"]), "validation_nrmse": nrmse.tolist()}

        # the ROM row and the job's success in one transaction, only while the job is not cancelled
        return store_and_finish(store(), job_id, save)

    run(job_id, body, finish=False)
