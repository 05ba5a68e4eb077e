"""Run (study) endpoints: create, list, summary, evaluations. Batches tagged with a run's id store every design."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Depends, Query, Response

from api.deps import Service, require_key, service, wing_or_404
from api.openapi import FOUND, READ, WING, WRITE
from api.problems import Problem
from api.schemas import RunCreate, RunEvaluations, RunSummary
from romams.persistence import ID_MAX
from romams.services.runs import FLUTTER_FIELDS, run_settings, run_summary

router = APIRouter(tags=["runs"], responses=READ)


def run_or_404(svc: Service, run_id: int) -> dict[str, Any]:
    """A run or a 404 problem naming run_id."""
    run = svc.store.runs.get(run_id)
    if run is None:
        raise Problem(404, f"run_id: no run {run_id}", "run_id")
    return run


def summary_of(svc: Service, run: dict[str, Any]) -> dict[str, Any]:
    """A run with its counts, best design and status (one unit of work)."""
    with svc.store.unit_of_work() as uow:
        return run_summary(run, uow.runs.counts(run["id"]), uow.runs.best(run["id"]),
                           uow.jobs.active_of_run(run["id"]))


@router.post("/runs", status_code=201, dependencies=[Depends(require_key)],
             responses={**WRITE, **WING, 201: {"model": RunSummary, "description": "the new run (Location header)"}})
def create_run(body: RunCreate, response: Response, svc: Service = Depends(service)) -> dict[str, Any]:
    """Create a run; tag batches with its id (``run_id``) to store their designs as its evaluations."""
    wid = None if body.wing is None else wing_or_404(svc, str(body.wing))[0]
    settings = run_settings(body.model_dump(include={"mu_kg", "mac_threshold", "envelope_tol_m", "penalty"}))
    run_id = svc.store.runs.create(body.name, settings, wing_id=wid)
    response.headers["Location"] = f"/api/v1/runs/{run_id}"
    return summary_of(svc, run_or_404(svc, run_id))


@router.get("/runs", responses={200: {"model": list[RunSummary], "description": "runs, newest first"}})
def list_runs(limit: int = Query(default=50, ge=1, le=500), offset: int = Query(default=0, ge=0, le=ID_MAX),
              svc: Service = Depends(service)) -> list[dict[str, Any]]:
    """Newest runs first, each with its summary."""
    return [summary_of(svc, r) for r in svc.store.runs.recent(limit, offset)]


@router.get("/runs/{run_id}", responses={**FOUND, 200: {"model": RunSummary, "description": "the run"}})
def get_run(run_id: int, svc: Service = Depends(service)) -> dict[str, Any]:
    """A run: counts of evaluations (feasible, infeasible, failed), best design so far, status, bytes per design."""
    return summary_of(svc, run_or_404(svc, run_id))


@router.get("/runs/{run_id}/evaluations",
            responses={**FOUND, 200: {"model": RunEvaluations, "description": "the evaluations after after_id"}})
def run_evaluations(run_id: int, after_id: int = Query(default=0, ge=0, le=ID_MAX),
                    limit: int = Query(default=1000, ge=1, le=10000),
                    svc: Service = Depends(service)) -> dict[str, Any]:
    """The run's evaluations in the order they were stored, those with id > ``after_id`` (poll with the last id
    seen). Each: x (design vector), mass_kg, objective (kg), feasible, envelope_ok, min_mac, error, evaluation_id
    (V-g data, when kept) and flutter: [[mach, v_eas_m_s, frequency_hz, flutter_mode, safe_altitude_m,
    benchmark_safe_altitude_m]] per Mach (v_eas_m_s: equivalent airspeed at flutter)."""
    run = run_or_404(svc, run_id)
    rows = svc.store.runs.evaluations(run_id, after_id, limit)
    return {"run_id": run["id"], "flutter_fields": list(FLUTTER_FIELDS), "evaluations": rows,
            "last_id": rows[-1]["id"] if rows else after_id}
