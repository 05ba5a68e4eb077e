"""Flutter evaluation endpoints: one structure (synchronous), batches, stored evaluations, V-g data, plots."""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np
from fastapi import APIRouter, Depends, Query, Request, Response
from fastapi.responses import JSONResponse
from starlette.concurrency import run_in_threadpool

from api.deps import Service, require_key, service, wing_or_404
from api.openapi import FOUND, IMAGE, LIMITED, READ, WING, WRITE
from api.plot_cache import DPI, MEDIA_TYPES, NOT_MODIFIED, plot_response
from api.problems import Problem, from_value_error, invalid
from api.responses import BatchResults, EvaluationOut, EvaluationSummary, JobAccepted, VgData, ok
from api.schemas import BatchRequest, FlutterRequest, FlutterSummary
from romams import jobs
from romams.persistence import FINAL, ID_MAX, ID_MIN, JobStatus
from romams.serialize import to_jsonable
from romams.services.errors import ServiceError
from romams.services.evaluation import evaluation_key
from romams.services.flight import FlightCondition
from romams.services.models import resolve_basis_id, trained_rom_ids
from romams.services.queue import TASK_FOR_KIND

router = APIRouter(tags=["flutter"], responses=READ)


def _basis_and_roms(svc: Service, wid: int, basis_id: int | None, machs: list[float] | None,
                    field: str = "machs", solver: str | None = None) -> tuple[int, list[list[float]]]:
    """Basis id (the wing's active one unless the request names one) and [(mach, rom_id)] to evaluate."""
    with svc.store.unit_of_work() as uow:  # one transaction for both reads
        bid = resolve_basis_id(uow, wid, basis_id)
        return bid, trained_rom_ids(uow, wid, bid, machs, field, solver)


def _condition(body: FlutterRequest | BatchRequest) -> FlightCondition:
    """The flight condition of a request (defaults where a field is absent)."""
    return FlightCondition.from_options(sweep=body.sweep, altitude_ref_m=body.altitude_ref_m, rho_ref=body.rho_ref,
                                        v_max_m_s=body.v_max_m_s, q_max_pa=body.q_max_pa,
                                        projection_correction=body.projection_correction)


def _design_vector(wing: Any, design: Any, field: str) -> list[float] | None:
    """Validated design vector (in the wing's variable order); 422 naming the field and the reason."""
    if design is None:
        if not getattr(wing, "has_baseline", False):
            raise invalid(field, "required: the wing has no baseline structure")
        return None
    if isinstance(design, list) and len(design) != len(wing.design_variables):
        raise invalid(field, f"expected {len(wing.design_variables)} values in the order {wing.variable_names}, "
                             f"got {len(design)}")
    try:
        vec = np.asarray(wing.design_vector(design), dtype=float)
    except ValueError as exc:
        raise from_value_error(exc, field) from exc
    if not np.all(np.isfinite(vec)):
        raise invalid(field, "contains non-finite values")
    return vec.tolist()


def _inline_modes(svc: Service, wing: Any, modes: dict[str, Any]) -> int:
    """Validate external modes against the wing's standard mesh and store them; returns the modes id."""
    from romams_core.mesh import standard_mesh
    from romams_core.modes_io import modes_from_dict, wing_modal_result

    try:
        m = modes_from_dict(modes, "json")
        if m.generalized_masses is not None:
            gm = np.asarray(m.generalized_masses, dtype=float)
            if gm.shape != m.frequencies_hz.shape or not np.all(gm > 0):
                raise ValueError("generalized_masses: must be positive, one per mode")
        if np.any(m.frequencies_hz <= 0):
            raise ValueError("frequencies_hz: must be > 0")
        wing_modal_result(m, wing, standard_mesh(wing.planform))
    except ValueError as exc:
        raise from_value_error(exc, "modes") from exc
    summary = {"n_nodes": int(m.nodes.shape[0]), "n_modes": int(m.shapes.shape[1])}
    return svc.store.modes.save(m, "json", summary=summary)


def _failed(job_id: str, outcome: dict[str, Any]) -> ServiceError:
    """The typed error of a failed job outcome (stored structured by the worker; else a 500 with its text)."""
    err = outcome.get("error") or {"status": 500, "field": None,
                                   "reason": f"evaluation failed: {str(outcome.get('text')).splitlines()[0]}"}
    out = ServiceError.from_dict(err)
    out.extra["job_id"] = job_id
    return out


def _row_outcome(job: dict[str, Any] | None) -> dict[str, Any] | None:
    """{status, result, error, text} of a final job row (None while the job is not final)."""
    if job is None or job["status"] not in FINAL:
        return None
    result = job["result"] if isinstance(job["result"], dict) else {}
    return {"status": job["status"], "result": job["result"], "error": result.get("error"),
            "text": job.get("error") or job["status"]}


def _submit(svc: Service, wing: str, body: FlutterRequest) -> dict[str, Any] | tuple[str, str]:
    """Validate a flutter request and submit its job: the stored answer of the same request (a dict), or
    (job kind, job id)."""
    wid, w = wing_or_404(svc, wing)
    bid, rom_ids = _basis_and_roms(svc, wid, body.basis_id, body.machs, solver=body.solver)
    design = None
    modes_id = body.modes_id
    if body.modes is not None:
        modes_id = _inline_modes(svc, w, body.modes.model_dump())
    elif modes_id is not None:
        try:
            svc.store.modes.load(modes_id)
        except KeyError as exc:
            raise Problem(404, f"modes_id: no uploaded modes {modes_id}", "modes_id") from exc
    else:
        design = _design_vector(w, body.design, "design")
    request = body.model_dump(exclude={"modes"})
    condition = _condition(body).to_json()
    h = evaluation_key(wid, bid, rom_ids, condition, design) if modes_id is None and body.method == "rom-ams" else None
    if h is not None and body.store:
        cached = svc.store.evaluations.find(h)
        if cached is not None:
            return {**cached["summary"], "evaluation_id": cached["id"], "cached": True}
    params = {"basis_id": bid, "rom_ids": rom_ids, "design": design, "modes_id": modes_id, "store": body.store,
              "request": request, "method": body.method, "content_hash": h, "condition": condition}
    if body.method == "rom-pms":  # trains one ROM per Mach on the structure's own modes: a training job
        return "flutter-pms", jobs.submit(svc.store, svc.celery, "flutter-pms", params, wing_id=wid)
    return "flutter", jobs.submit(svc.store, svc.celery, "flutter", params, wing_id=wid)


@router.post("/wings/{wing}/flutter", dependencies=[Depends(require_key)],
             responses={**WRITE, **WING, **LIMITED,
                        200: {"model": FlutterSummary, "description": "the evaluation (v_flutter_m_s is the true "
                                                                      "airspeed; v_eas_m_s the equivalent one)"},
                        **ok(JobAccepted, "not finished within sync_timeout_s, or rom-pms: the job", 202)})
async def flutter(wing: str, body: FlutterRequest, response: Response, svc: Service = Depends(service)) -> Any:
    """Flutter evaluation of one structure at the trained (or given) Mach numbers; synchronous (up to
    sync_timeout_s; the wait holds no server thread)."""
    submitted = await run_in_threadpool(_submit, svc, wing, body)
    if isinstance(submitted, dict):
        return submitted
    kind, job_id = submitted
    out = None
    if kind == "flutter":  # rom-pms trains ROMs: always a job
        out = await jobs.wait_result_async(svc.celery, job_id, svc.settings.sync_timeout_s)
        if out is not None and out.get("status") is None:  # not run by this delivery (e.g. redelivered)
            out = _row_outcome(await run_in_threadpool(svc.store.jobs.get, job_id))
    if out is None:
        response.status_code = 202
        response.headers["Location"] = f"/api/v1/jobs/{job_id}"
        return {"job_id": job_id, "status": JobStatus.QUEUED}
    if out["status"] != JobStatus.SUCCEEDED:
        raise _failed(job_id, {"text": out["status"], **out})
    # the worker's summary is JSON already: send it as is (no second encoding pass over the nested result)
    return JSONResponse({**out["result"], "job_id": job_id})


@router.post("/wings/{wing}/flutter/batch", dependencies=[Depends(require_key)],
             responses={**WRITE, **WING, **LIMITED, **ok(BatchResults, "every design's flutter summary, in order"),
                        **ok(JobAccepted, "a large batch, or one not finished within sync_timeout_s", 202)})
async def flutter_batch(wing: str, body: BatchRequest, response: Response,
                        svc: Service = Depends(service)) -> dict[str, Any]:
    """Batch of designs: results in order (synchronous up to batch_sync_max designs, else 202 with a job; the wait
    holds no server thread)."""
    parent, n = await run_in_threadpool(_submit_batch, svc, wing, body)
    if n > svc.settings.batch_sync_max:
        response.status_code = 202
        response.headers["Location"] = f"/api/v1/jobs/{parent}"
        return {"job_id": parent, "status": JobStatus.QUEUED, "n": n}
    job = await jobs.wait_for_async(svc.store, parent, svc.settings.sync_timeout_s)
    if job is None:
        response.status_code = 202
        response.headers["Location"] = f"/api/v1/jobs/{parent}"
        return {"job_id": parent, "status": JobStatus.RUNNING, "n": n}
    if job["status"] != JobStatus.SUCCEEDED:
        raise _failed(parent, _row_outcome(job) or {})
    return {"results": job["result"]["results"], "job_id": parent, **({"run_id": body.run_id} if body.run_id else {})}


def _submit_batch(svc: Service, wing: str, body: BatchRequest) -> tuple[str, int]:
    """Validate a batch and submit its parent and chunk jobs: (parent job id, number of designs)."""
    wid, w = wing_or_404(svc, wing)
    n = len(body.designs)
    if n > svc.settings.batch_max:
        raise Problem(413, f"designs: at most {svc.settings.batch_max} designs per batch, got {n}", "designs")
    bid, rom_ids = _basis_and_roms(svc, wid, body.basis_id, body.machs, solver=body.solver)
    vectors = [_design_vector(w, d, f"designs[{i}]") for i, d in enumerate(body.designs)]
    chunk = max(1, min(svc.settings.batch_chunk, math.ceil(n / 4)))
    condition = _condition(body).to_json()
    params = {"basis_id": bid, "rom_ids": rom_ids, "n": n, "method": body.method, "condition": condition}
    tag = _run_tag(svc, body, wid)
    with svc.store.unit_of_work() as uow:  # parent and chunks committed together, before any message is sent
        parent = uow.jobs.create("flutter-batch", {**params, **tag}, wing_id=wid, stage="fanout",
                                 message=f"{n} designs in {math.ceil(n / chunk)} chunks", run_id=body.run_id)
        kids = [uow.jobs.create("flutter-chunk", {"basis_id": bid, "rom_ids": rom_ids, "index": k,
                                                  "condition": condition, "designs": vectors[i:i + chunk], **tag},
                                wing_id=wid, parent_id=parent, run_id=body.run_id)
                for k, i in enumerate(range(0, n, chunk))]
    try:
        for k in kids:
            jobs.send(svc.celery, TASK_FOR_KIND["flutter-chunk"], k, svc.store)
    except jobs.BrokerUnavailable:
        svc.store.jobs.cancel(parent)
        raise
    return parent, n


def _run_tag(svc: Service, body: BatchRequest, wid: int) -> dict[str, Any]:
    """Job parameters of a batch tagged with a run: its id, feasibility settings and keep_vg (404/422 naming
    run_id for an unknown run or one of another wing); {} without a run. A run without a wing takes this one."""
    if body.run_id is None:
        if body.keep_vg:
            raise invalid("keep_vg", "only with a run_id (the V-g data are kept as evaluations of the run)")
        return {}
    run = svc.store.runs.get(body.run_id)
    if run is None:
        raise Problem(404, f"run_id: no run {body.run_id}", "run_id")
    if run["wing_id"] is None:
        svc.store.runs.set_wing(body.run_id, wid)
    elif run["wing_id"] != wid:
        raise invalid("run_id", f"run {body.run_id} evaluates wing {run['wing_id']}, not wing {wid}")
    return {"run_id": body.run_id, "run_settings": run["settings"], "keep_vg": body.keep_vg}


# ---- stored evaluations ---------------------------------------------------------------------------
def _evaluation_or_404(svc: Service, evaluation_id: int, full: bool = False) -> dict[str, Any]:
    """Stored evaluation or a 404 problem."""
    ev = svc.store.evaluations.get(evaluation_id, full=full)
    if ev is None:
        raise Problem(404, f"evaluation_id: no evaluation {evaluation_id}", "evaluation_id")
    return ev


@router.get("/evaluations", responses=ok(list[EvaluationSummary], "newest first"))
def list_evaluations(wing_id: int | None = Query(default=None, ge=ID_MIN, le=ID_MAX),
                     limit: int = Query(default=20, ge=1, le=500),
                     svc: Service = Depends(service)) -> list[dict[str, Any]]:
    """Newest stored evaluations (summaries)."""
    return svc.store.evaluations.recent(wing_id, limit)


@router.get("/evaluations/{evaluation_id}", responses={**FOUND, **ok(EvaluationOut, "the evaluation")})
def get_evaluation(evaluation_id: int, svc: Service = Depends(service)) -> dict[str, Any]:
    """A stored evaluation: request and summary."""
    return _evaluation_or_404(svc, evaluation_id)


def flutter_results(result: Any) -> list[Any]:
    """Per-Mach FlutterResult objects of a stored evaluation result."""
    return list(getattr(result, "flutter", []) or [])


@router.get("/evaluations/{evaluation_id}/vg", responses={**FOUND, **ok(VgData, "V-g data by Mach")})
def vg_data(evaluation_id: int, svc: Service = Depends(service)) -> dict[str, Any]:
    """V-g and V-omega data of every Mach: speeds (m/s), q (Pa), damping g and frequencies (rad/s) per branch."""
    ev = _evaluation_or_404(svc, evaluation_id, full=True)
    out = []
    for r in flutter_results(ev["result"]):
        out.append({"mach": r.mach, "sweep": r.sweep, "v_m_s": r.v, "q_pa": r.q, "rho": r.rho,
                    "altitude_m": r.altitude, "g": r.g, "omega_rad_s": r.omega,
                    "v_flutter_m_s": r.v_flutter_m_s, "omega_flutter_rad_s": r.omega_flutter_rad_s,
                    "flutter_mode": r.flutter_mode})
    return to_jsonable({"evaluation_id": evaluation_id, "machs": out})


@router.get("/evaluations/{evaluation_id}/plot.{fmt}", response_class=Response,
            responses={**FOUND, **IMAGE, **NOT_MODIFIED})
def evaluation_plot(request: Request, evaluation_id: int, fmt: Literal["png", "svg"],
                    kind: Literal["vg", "envelope"] = "vg", mach: float | None = Query(default=None, gt=0, lt=5),
                    axis: Literal["tas", "eas", "q"] = Query(default="tas", description=(
                        "speed axis of the V-g plot: true airspeed (tas), equivalent airspeed (eas) or dynamic "
                        "pressure (q)")),
                    svc: Service = Depends(service)) -> Response:
    """V-g / V-f plot of one Mach (default: the first) from q = 0 on the chosen speed axis, or the envelope of this
    design against its benchmark (PNG/SVG); cached by the hash of the data drawn, with an ETag (304 on a match)."""
    from romams.plots import flutter as flutter_plots

    ev = _evaluation_or_404(svc, evaluation_id, full=True)
    results = flutter_results(ev["result"])
    if kind == "vg":
        if not results:
            raise Problem(404, f"evaluation_id: evaluation {evaluation_id} has no flutter results", "evaluation_id")
        pick = results[0]
        if mach is not None:
            found = [r for r in results if abs(float(r.mach) - mach) < 1e-6]
            if not found:
                raise invalid("mach", f"{mach} is not in this evaluation; Machs: {[float(r.mach) for r in results]}")
            pick = found[0]
        return plot_response(request, fmt, ("vg", pick, axis), lambda: flutter_plots.vg_figure(pick, axis=axis))
    name = f"evaluation {evaluation_id}"
    env, comp = ev["result"].envelope, getattr(ev["result"], "comparison", None)
    comps = {} if comp is None else {name: comp}
    return plot_response(request, fmt, ("envelope", name, env, comp),
                         lambda: flutter_plots.envelope_figure({name: env}, comparisons=comps))


def figure_response(fig: Any, fmt: str) -> Response:
    """Render a matplotlib figure to a PNG/SVG response (uncached; plot_cache.plot_response caches by content)."""
    from romams.plots.flutter import figure_bytes

    return Response(figure_bytes(fig, fmt, dpi=DPI), media_type=MEDIA_TYPES[fmt])
