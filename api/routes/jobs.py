"""Job endpoints: list (filters, pages), get, cancel."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Depends, Query, Response

from api.deps import Service, no_nul, require_key, service
from api.openapi import FOUND, READ, WRITE, problems
from api.problems import Problem
from api.responses import ok
from api.schemas import JobOut
from romams.persistence import ID_MAX, ID_MIN, JobStatus

router = APIRouter(tags=["jobs"], responses=READ)


def job_or_404(svc: Service, job_id: str) -> dict[str, Any]:
    """Job dict or a 404 problem naming the job id (422 for a NUL character)."""
    no_nul(job_id, "job_id")
    job = svc.store.jobs.get(job_id) if len(job_id) <= 64 else None
    if job is None:
        raise Problem(404, f"job_id: no job {job_id!r}", "job_id")
    return job


@router.get("/jobs", responses=ok(list[JobOut], "jobs, newest first (X-Total-Count: matching jobs)"))
def list_jobs(response: Response, status: JobStatus | None = None,
              kind: str | None = Query(default=None, max_length=40), limit: int = Query(default=50, ge=1, le=1000),
              include_children: bool = False,
              wing_id: int | None = Query(default=None, ge=ID_MIN, le=ID_MAX),
              run_id: int | None = Query(default=None, ge=ID_MIN, le=ID_MAX),
              include_runs: bool = Query(default=True, description="false: leave out the batches of runs (they are "
                                         "listed with run_id=...), so optimization generations do not flood the list"),
              offset: int = Query(default=0, ge=0, le=ID_MAX, description="skip this many of the newest (pages)"),
              svc: Service = Depends(service)) -> list[dict[str, Any]]:
    """Newest jobs first (fan-out chunk jobs only with include_children=true); filters by status, kind, wing and
    run; the X-Total-Count header gives the number of matching jobs."""
    no_nul(kind, "kind")
    filters = {"status": status, "kind": kind, "top_level": not include_children, "wing_id": wing_id,
               "run_id": run_id, "include_runs": include_runs}
    with svc.store.unit_of_work() as uow:
        response.headers["X-Total-Count"] = str(uow.jobs.count(**filters))
        return uow.jobs.recent(limit=limit, offset=offset, **filters)


@router.get("/jobs/{job_id}", responses={**FOUND, **ok(JobOut, "the job")})
def get_job(job_id: str, svc: Service = Depends(service)) -> dict[str, Any]:
    """One job: status, progress 0..1, message, result, error, timestamps."""
    return job_or_404(svc, job_id)


@router.post("/jobs/{job_id}/cancel", dependencies=[Depends(require_key)], responses={**WRITE, **problems(404, 409),
                                                                                    **ok(JobOut, "the cancelled job")})
def cancel_job(job_id: str, svc: Service = Depends(service)) -> dict[str, Any]:
    """Cancel a queued or running job (its task stops at its next progress step)."""
    job = job_or_404(svc, job_id)
    if not svc.store.jobs.cancel(job_id):
        raise Problem(409, f"job_id: job {job_id} is already {job['status']}", "job_id",
                      extra={"job_status": job["status"]})
    return svc.store.jobs.get(job_id) or job
