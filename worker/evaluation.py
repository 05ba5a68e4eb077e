"""Flutter evaluation tasks (queue "evaluation"): one structure, or a chunk of a batch.

Thin: a task loads the models by id through the worker's caches and calls the one evaluation use case
(``romams.services.evaluation``), which the CLI and the demo call too. Batch results are also cached by
a content hash of (wing, basis, ROMs, flight condition, design). A synchronous evaluation returns its
outcome through the Celery result backend, so the API gets the answer without polling the database.
"""

from __future__ import annotations

from typing import Any

from romams.jobs import JobFailed, Outcome, ProgressFn, fanout_outcome, store_and_finish
from romams.persistence import JobStatus, UnitOfWork
from romams.services.evaluation import (
    Models,
    evaluate_designs,
    evaluate_structure_summary,
    evaluation_key,
    pms_summary,
    structure_modal,
)
from romams.services.flight import FlightCondition
from romams.services.models import load_models
from romams.services.runs import compact_row
from worker.cache import ResultCache
from worker.celery_app import app
from worker.context import (
    OBJECTS,
    load_basis,
    load_mesh,
    load_rom,
    load_wing,
    run,
    settings,
    store,
    train_model,
)

#: content hash -> summary of one design (compact JSON, bounded by entries and by result_cache_mb)
RESULTS = ResultCache(settings.result_cache_size, settings.result_cache_mb << 20)


def models_for(wing_id: int, basis_id: int, rom_ids: list[list[float]]) -> Models:
    """The evaluation models from ids (wing, mesh, basis and ROMs come from the worker's cache)."""
    return load_models(wing_id, load_wing(wing_id), basis_id, rom_ids, load_basis, load_rom, load_mesh)


def condition_of(params: dict[str, Any]) -> FlightCondition:
    """The flight condition stored with a job's parameters (default when absent)."""
    return FlightCondition.from_options(**dict(params.get("condition") or {}))


def evaluate(wing_id: int, basis_id: int, rom_ids: list[list[float]], design: list[float] | None,
             modes_id: int | None = None, condition: FlightCondition | None = None) -> tuple[dict[str, Any], Any]:
    """Evaluate one structure with the use case -> (JSON summary, StructureEvaluation)."""
    models = models_for(wing_id, basis_id, rom_ids)
    modes = None if modes_id is None else store().modes.load(int(modes_id))
    return evaluate_structure_summary(models, design=design, modes=modes, condition=condition or FlightCondition(),
                                      cache=OBJECTS.get_or_load)


def batch_key(wing_id: int, params: dict[str, Any], design: Any) -> str:
    """The evaluation key of one design of a job (romams.services.evaluation.evaluation_key)."""
    return evaluation_key(wing_id, params["basis_id"], params["rom_ids"], params.get("condition") or {}, design)


@app.task(name="romams.evaluation.flutter", bind=True, acks_late=True, ignore_result=False,
          time_limit=settings.evaluation_time_limit_s)
def flutter_job(self: Any, job_id: str) -> dict[str, Any]:
    """One structure: evaluate, store the evaluation (V-g data); the outcome goes to the result backend (first,
    for the waiting API request) and to the job row."""

    def reply(outcome: Outcome) -> None:
        self.backend.store_result(self.request.id, outcome.as_dict(), "SUCCESS")

    def body(job: dict[str, Any], progress: ProgressFn) -> dict[str, Any]:
        p = job["params"]
        keep = bool(p.get("store", True))
        h = None
        if p.get("modes_id") is None:  # same key as the batch chunks: a design seen before is answered from memory
            h = batch_key(job["wing_id"], p, p.get("design"))
            if not keep and (hit := RESULTS.get(h)) is not None and "error" not in hit:
                return hit
        summary, result = evaluate(job["wing_id"], p["basis_id"], p["rom_ids"], p.get("design"), p.get("modes_id"),
                                   condition_of(p))
        if h is not None:
            RESULTS.put(h, summary)
        if keep:
            summary["evaluation_id"] = store().evaluations.save(
                job["wing_id"], result, summary=summary, request=p.get("request") or {}, basis_id=p["basis_id"],
                method=p.get("method", "rom-ams"), content_hash=p.get("content_hash"))
        return summary

    return run(job_id, body, reply=reply).as_dict()


def evaluate_pms(wing_id: int, basis_id: int, rom_ids: list[list[float]], design: list[float] | None,
                 modes_id: int | None, progress: ProgressFn,
                 condition: FlightCondition | None = None) -> tuple[dict[str, Any], Any]:
    """ROM-PMS reference: train on the structure's own modes at each Mach with the stored ROMs' settings."""
    condition = condition or FlightCondition()
    models = models_for(wing_id, basis_id, rom_ids)
    modes = None if modes_id is None else store().modes.load(int(modes_id))
    modal = structure_modal(models, design, modes)
    rows = {int(r["id"]): r for r in store().roms.of_wing(wing_id, basis_id)}
    own: dict[float, tuple[int, Any]] = {}
    for i, (mach, rid) in enumerate(rom_ids):
        ident = rows[int(rid)]["params"]
        progress(i / len(rom_ids), f"ROM-PMS: training M = {mach:g} on the structure's own modes")
        own[float(mach)] = (int(rid), train_model(models.mesh, modal.shapes, float(mach), ident,
                                                  f"ROM-PMS training at M = {mach:g}"))
    return pms_summary(models, modal, own, condition, external=modes_id is not None, cache=OBJECTS.get_or_load)


@app.task(name="romams.training.flutter_pms", acks_late=True, time_limit=settings.training_time_limit_s)
def flutter_pms_job(job_id: str) -> None:
    """One structure by ROM-PMS (the accuracy reference): train on its own modes, evaluate, store."""

    def body(job: dict[str, Any], progress: ProgressFn) -> dict[str, Any]:
        p = job["params"]
        summary, result = evaluate_pms(job["wing_id"], p["basis_id"], p["rom_ids"], p.get("design"),
                                       p.get("modes_id"), progress, condition_of(p))
        if not p.get("store", True):
            return summary

        def save(uow: UnitOfWork) -> dict[str, Any]:
            summary["evaluation_id"] = uow.evaluations.save(
                job["wing_id"], result, summary=summary, request=p.get("request") or {}, basis_id=p["basis_id"],
                method="rom-pms")
            return summary

        return store_and_finish(store(), job_id, save)  # stored only while the job is not cancelled

    run(job_id, body)


@app.task(name="romams.evaluation.flutter_chunk", acks_late=True, time_limit=settings.evaluation_time_limit_s)
def flutter_chunk(job_id: str) -> None:
    """A chunk of a batch: summaries of each design (cached by content hash); the last chunk assembles the batch.
    A chunk of a run stores every design as a run evaluation, in the transaction that ends the chunk."""

    def body(job: dict[str, Any], progress: ProgressFn) -> dict[str, Any]:
        p = job["params"]
        designs = p["designs"]
        keys = [batch_key(job["wing_id"], p, d) for d in designs]
        keep_vg = bool(p.get("keep_vg"))
        out = [None if keep_vg else RESULTS.get(h) for h in keys]  # V-g data asked for: evaluate every design
        full: list[Any] = [None] * len(designs)
        todo = [i for i, s in enumerate(out) if s is None]
        if todo:  # the designs not seen before, evaluated together (one batched flutter search per Mach)
            models = models_for(job["wing_id"], p["basis_id"], p["rom_ids"])
            # the V-g curves are kept only when asked for; else the checks that only correct them are skipped,
            # and the chunk's best design, stored with its curves, is evaluated again with them (fill_best)
            fresh = evaluate_designs(models, [designs[i] for i in todo], condition=condition_of(p),
                                     cache=OBJECTS.get_or_load, vg_checks=keep_vg)
            for i, (summary, result) in zip(todo, fresh, strict=True):
                RESULTS.put(keys[i], summary)
                out[i], full[i] = summary, result if keep_vg else None
        progress(1.0, f"{len(designs)}/{len(designs)} designs")
        result = {"index": p["index"], "results": out}
        if p.get("run_id") is None:
            return result
        rows = [compact_row(d, s, p["run_settings"], job["parent_id"]) for d, s in zip(designs, out, strict=True)]
        fill_best(job, designs, rows, full)

        def save(uow: UnitOfWork) -> dict[str, Any]:
            save_run_chunk(uow, job, keys, out, full, rows)
            return result

        return store_and_finish(store(), job_id, save)  # stored only while the chunk is not cancelled

    run(job_id, body)
    job = store().jobs.get(job_id)
    if job and job["parent_id"] and job["status"] in (JobStatus.SUCCEEDED, JobStatus.FAILED):
        assemble_batch(job["parent_id"])


def chunk_best(rows: list[dict[str, Any]], best: float | None) -> int | None:
    """Index of the chunk's best feasible design when it beats the run's best objective ``best`` (None: no run best
    yet), else None."""
    cands = [i for i, r in enumerate(rows) if r["feasible"]]
    if not cands:
        return None
    i = min(cands, key=lambda k: rows[k]["objective"])
    return i if best is None or rows[i]["objective"] < best else None


def fill_best(job: dict[str, Any], designs: list[Any], rows: list[dict[str, Any]], full: list[Any]) -> None:
    """The full result (V-g data) of the chunk's new best design (``chunk_best``) when the chunk has none for it
    (answered from the result cache, which keeps summaries only, or evaluated without the V-g checks): evaluated
    again, into ``full``."""
    p = job["params"]
    i = chunk_best(rows, store().runs.best_objective(int(p["run_id"])))
    if i is not None and full[i] is None:
        models = models_for(job["wing_id"], p["basis_id"], p["rom_ids"])
        ((_, full[i]),) = evaluate_designs(models, [designs[i]], condition=condition_of(p), cache=OBJECTS.get_or_load)


def save_run_chunk(uow: UnitOfWork, job: dict[str, Any], keys: list[str], summaries: list[Any],
                   full: list[Any], rows: list[dict[str, Any]]) -> None:
    """Store a chunk's designs (their compact ``rows``) as evaluations of its run (one INSERT); V-g data (an
    evaluation row) only for the designs asked for (``keep_vg``) and for the chunk's new best (``chunk_best``)."""
    p = job["params"]
    run_id, designs = int(p["run_id"]), p["designs"]
    rows = [dict(r) for r in rows]  # this transaction's own copies (it may be run again)
    keep = {i for i, r in enumerate(full) if r is not None} if p.get("keep_vg") else set()
    i = chunk_best(rows, uow.runs.best_objective(run_id))
    if i is not None and full[i] is not None:  # filled in by fill_best when it came from the result cache
        keep.add(i)
    for i in sorted(keep):
        rows[i]["evaluation_id"] = uow.evaluations.save(
            job["wing_id"], full[i], summary=summaries[i], request={"design": designs[i], "run_id": run_id},
            basis_id=p["basis_id"], method="rom-ams", content_hash=keys[i])
    uow.runs.add_evaluations(run_id, rows)


def assemble_batch(parent_id: str) -> None:
    """After a chunk: update the batch's progress; when all chunks succeeded, the claimer writes the results."""
    s = store()
    kids = fanout_outcome(s, parent_id)
    if kids is None:
        return
    done = [k for k in kids if k["status"] == JobStatus.SUCCEEDED]
    s.jobs.update(parent_id, expect=(JobStatus.QUEUED,), status=JobStatus.RUNNING)
    s.jobs.progress(parent_id, len(done) / max(len(kids), 1), f"{len(done)}/{len(kids)} chunks done")
    if len(done) == len(kids) and s.jobs.claim_stage(parent_id, "fanout", "finalize"):
        results: list[Any] = []
        for k in sorted(done, key=lambda k: k["params"]["index"]):
            results.extend(k["result"]["results"])
        s.jobs.finish(parent_id, JobStatus.SUCCEEDED, result={"results": results, "n": len(results)}, message="done")


@app.task(name="romams.evaluation.batch_finalize", acks_late=True, time_limit=settings.evaluation_time_limit_s)
def batch_finalize(job_id: str) -> None:
    """Re-run the batch assembly (sent by the stale-job sweeper if the assembling worker died)."""
    s = store()
    if s.jobs.claim_stage(job_id, "finalize", "fanout"):
        assemble_batch(job_id)


__all__ = ["JobFailed", "Outcome", "assemble_batch", "evaluate", "evaluate_pms", "flutter_chunk", "flutter_job",
           "flutter_pms_job", "chunk_best", "fill_best", "save_run_chunk"]
