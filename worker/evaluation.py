"""Flutter evaluation tasks (queue "evaluation"): one structure, or a chunk of a batch.

A structure is either a design vector of the wing (modal analysis here) or stored external modes.
Its modes are projected on the basis and every trained Mach's ROM is turned into modal coordinates
and coupled with the structure by romams_core.evaluate. Loaded bases/ROMs stay in the worker's
bounded cache; batch results are also cached by a content hash of (wing, basis, ROMs, design).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from romams.jobs import JobFailed, ProgressFn
from romams.persistence import JobStatus, content_hash
from romams.serialize import to_jsonable
from worker.cache import LruCache
from worker.celery_app import app
from worker.tasks import (
    OBJECTS,
    _run,
    _settings,
    chunk_outcome,
    load_basis,
    load_mesh,
    load_rom,
    load_wing,
    store,
)

RESULTS = LruCache(_settings.result_cache_size)  # content hash -> summary dict of one design


def _f(x: Any) -> float | None:
    """Finite float or None."""
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


def structure_modal(wing_id: int, design: list[float] | None, modes_id: int | None, n_modes: int) -> Any:
    """ModalResult of a design of the wing, or of stored external modes mapped to the standard mesh."""
    if modes_id is not None:
        from romams_core.modes_io import external_modal_result

        modes = store().modes.load(int(modes_id))
        return external_modal_result(modes, load_mesh(wing_id))
    from romams_core.structure.modal import modal_analysis

    wing = load_wing(wing_id)
    if design is None:  # the baseline: one cached eigensolve, so that it compares with itself exactly
        return OBJECTS.get_or_load(("baseline-modal", int(wing_id), int(n_modes)),
                                   lambda: modal_analysis(wing, design=None, n_modes=n_modes))
    return modal_analysis(wing, design=np.asarray(design, dtype=float), n_modes=n_modes)


def _zeta(wing: Any) -> float | None:
    """The wing's modal damping ratio for the flutter analysis (None = undamped), as the CLI applies it."""
    z = float(getattr(wing, "modal_damping", 0.0) or 0.0)
    return z if z > 0 else None


def _roms(rom_ids: list[list[float]]) -> dict[float, Any]:
    """{mach: TrainedRom} of the (mach, rom_id) pairs (cached)."""
    return {float(m): load_rom(int(rid)) for m, rid in rom_ids}


def baseline_evaluation(wing_id: int, basis_id: int, rom_ids: list[list[float]]) -> Any:
    """StructureEvaluation of the wing's baseline structure on these ROMs (cached), or None without a baseline."""
    from romams_core.evaluate import evaluate_structure

    wing = load_wing(wing_id)
    if not getattr(wing, "has_baseline", False):
        return None

    def load() -> Any:
        basis = load_basis(basis_id)
        modal = structure_modal(wing_id, None, None, int(basis.n_modes))
        return evaluate_structure(modal, basis.shapes, _roms(rom_ids), mac_threshold=float(basis.mac_threshold),
                                  zeta=_zeta(wing))

    key = ("baseline", int(wing_id), int(basis_id), tuple((float(m), int(r)) for m, r in rom_ids))
    return OBJECTS.get_or_load(key, load)


def evaluate(wing_id: int, basis_id: int, rom_ids: list[list[float]], design: list[float] | None,
             modes_id: int | None = None) -> tuple[dict[str, Any], Any]:
    """Evaluate one structure at the given (mach, rom_id) pairs -> (API summary, StructureEvaluation).

    The envelope is compared with the wing's baseline evaluated on the same ROMs (when it has one).
    """
    from romams_core.evaluate import evaluate_structure

    basis = load_basis(basis_id)
    modal = structure_modal(wing_id, design, modes_id, int(basis.n_modes))
    base = baseline_evaluation(wing_id, basis_id, rom_ids)
    result = evaluate_structure(modal, basis.shapes, _roms(rom_ids), mac_threshold=float(basis.mac_threshold),
                                benchmark=None if base is None else base.envelope, zeta=_zeta(load_wing(wing_id)))
    return summarize(result, external=modes_id is not None), result


def summarize(result: Any, external: bool = False) -> dict[str, Any]:
    """The API's JSON view of a StructureEvaluation: mass, frequencies, MACs, per-Mach flutter points, envelope."""
    env = result.envelope
    env_machs = np.asarray(env.mach, dtype=float)
    per_mach = []
    for r in result.flutter:
        idx = np.flatnonzero(np.isclose(env_machs, float(r.mach), rtol=0, atol=1e-9))
        per_mach.append({
            "mach": _f(r.mach), "v_flutter_m_s": _f(r.v_flutter_m_s), "omega_flutter_rad_s": _f(r.omega_flutter_rad_s),
            "q_flutter_pa": _f(r.q_flutter_pa), "sdoff": bool(r.sdoff), "flutter_mode": r.flutter_mode,
            "flutter_found": bool(r.flutter_found), "sweep": r.sweep, "message": r.message,
            "safe_altitude_m": _f(env.safe_altitude_m[idx[0]]) if idx.size else None,
            "envelope_status": env.status[idx[0]] if idx.size else None,
        })
    mass = _f(result.mass_kg)
    comp = result.comparison
    return to_jsonable({
        "mass_kg": None if external and not (mass and mass > 0) else mass,
        "frequencies_hz": np.asarray(result.frequencies_hz, dtype=float),
        "mac": np.asarray(result.mac, dtype=float),
        "min_mac": _f(result.min_mac),
        "mac_ok": bool(result.mac_ok),
        "sdoff": bool(result.sdoff),
        "results": per_mach,
        "envelope_ok": None if comp is None else bool(comp.envelope_ok),
        "envelope_margin_m": None if comp is None else np.asarray(comp.margin_m, dtype=float),
        "constraints_ok": bool(result.constraints_ok),
        "message": result.message,
    })


@app.task(name="romams.evaluation.flutter", acks_late=True, time_limit=_settings.evaluation_time_limit_s)
def flutter_job(job_id: str) -> None:
    """One structure: evaluate, store the evaluation (V-g data) and put the summary in the job result."""

    def body(job: dict[str, Any], progress: ProgressFn) -> dict[str, Any]:
        p = job["params"]
        keep = bool(p.get("store", True))
        h = None
        if p.get("modes_id") is None:  # same key as the batch chunks: a design seen before is answered from memory
            h = content_hash("flutter", job["wing_id"], p["basis_id"], p["rom_ids"], p.get("design"))
            if not keep and (hit := RESULTS.get(h)) is not None and "error" not in hit:
                return dict(hit)
        summary, result = evaluate(job["wing_id"], p["basis_id"], p["rom_ids"], p.get("design"), p.get("modes_id"))
        if h is not None:
            RESULTS.put(h, dict(summary))
        if keep:
            summary["evaluation_id"] = store().evaluations.save(
                job["wing_id"], result, summary=summary, request=p.get("request") or {}, basis_id=p["basis_id"],
                method=p.get("method", "rom-ams"), content_hash=p.get("content_hash"))
        return summary

    _run(job_id, body)


def evaluate_pms(wing_id: int, basis_id: int, rom_ids: list[list[float]], design: list[float] | None,
                 modes_id: int | None, progress: ProgressFn) -> tuple[dict[str, Any], Any]:
    """ROM-PMS reference: train on the structure's own modes at each Mach with the stored ROMs' settings."""
    from romams_core.evaluate import evaluate_structure
    from romams_core.training import TrainingError, train_rom
    from worker.tasks import make_solver

    basis = load_basis(basis_id)
    modal = structure_modal(wing_id, design, modes_id, int(basis.n_modes))
    rows = {int(r["id"]): r for r in store().roms.of_wing(wing_id, basis_id)}
    own: dict[float, Any] = {}
    for i, (mach, rid) in enumerate(rom_ids):
        ident = rows[int(rid)]["params"]
        progress(i / len(rom_ids), f"ROM-PMS: training M = {mach:g} on the structure's own modes")
        try:
            own[float(mach)] = train_rom(load_mesh(wing_id), modal.shapes, float(mach), make_solver(ident["solver"]),
                                         na=int(ident["na"]), nb=int(ident["nb"]), **dict(ident.get("options") or {}))
        except TrainingError as exc:
            raise JobFailed(f"ROM-PMS training at M = {mach:g} failed: {exc}") from exc
    base = baseline_evaluation(wing_id, basis_id, rom_ids)
    # the structure's own modes are the "basis": gamma = I, MAC = 1
    result = evaluate_structure(modal, modal.shapes, own, benchmark=None if base is None else base.envelope,
                                zeta=_zeta(load_wing(wing_id)))
    summary = summarize(result, external=modes_id is not None)
    summary["method"] = "rom-pms"
    return summary, result


@app.task(name="romams.training.flutter_pms", acks_late=True, time_limit=_settings.training_time_limit_s)
def flutter_pms_job(job_id: str) -> None:
    """One structure by ROM-PMS (the accuracy reference): train on its own modes, evaluate, store."""

    def body(job: dict[str, Any], progress: ProgressFn) -> dict[str, Any]:
        p = job["params"]
        summary, result = evaluate_pms(job["wing_id"], p["basis_id"], p["rom_ids"], p.get("design"),
                                       p.get("modes_id"), progress)
        if p.get("store", True):
            summary["evaluation_id"] = store().evaluations.save(
                job["wing_id"], result, summary=summary, request=p.get("request") or {}, basis_id=p["basis_id"],
                method="rom-pms")
        return summary

    _run(job_id, body)


@app.task(name="romams.evaluation.flutter_chunk", acks_late=True, time_limit=_settings.evaluation_time_limit_s)
def flutter_chunk(job_id: str) -> None:
    """A chunk of a batch: summaries of each design (cached by content hash); the last chunk assembles the batch."""

    def body(job: dict[str, Any], progress: ProgressFn) -> dict[str, Any]:
        p = job["params"]
        out = []
        designs = p["designs"]
        for i, d in enumerate(designs):
            h = content_hash("flutter", job["wing_id"], p["basis_id"], p["rom_ids"], d)
            summary = RESULTS.get(h)
            if summary is None:
                try:
                    summary, _ = evaluate(job["wing_id"], p["basis_id"], p["rom_ids"], d)
                except ValueError as exc:  # a design the structure model rejects: reported per design
                    summary = {"error": str(exc)}
                RESULTS.put(h, summary)
            out.append(summary)
            if (i + 1) % 8 == 0:
                progress((i + 1) / len(designs), f"{i + 1}/{len(designs)} designs")
        return {"index": p["index"], "results": out}

    _run(job_id, body)
    job = store().jobs.get(job_id)
    if job and job["parent_id"] and job["status"] in (JobStatus.SUCCEEDED, JobStatus.FAILED):
        assemble_batch(job["parent_id"])


def assemble_batch(parent_id: str) -> None:
    """After a chunk: update the batch's progress; when all chunks succeeded, the claimer writes the results."""
    s = store()
    kids = chunk_outcome(s, parent_id)
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


@app.task(name="romams.evaluation.batch_finalize", acks_late=True, time_limit=_settings.evaluation_time_limit_s)
def batch_finalize(job_id: str) -> None:
    """Re-run the batch assembly (sent by the stale-job sweeper if the assembling worker died)."""
    s = store()
    if s.jobs.claim_stage(job_id, "finalize", "fanout"):
        assemble_batch(job_id)


__all__ = ["JobFailed", "assemble_batch", "evaluate", "evaluate_pms", "flutter_chunk", "flutter_job",
           "flutter_pms_job", "summarize"]
