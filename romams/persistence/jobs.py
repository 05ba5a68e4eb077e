"""Job rows: the source of truth of every background job, changed only by guarded updates.

A transition is an ``UPDATE ... WHERE status IN (...)`` so that concurrent workers, redeliveries and
cancellation cannot overwrite a final state; each method says which states it moves from.
"""

from __future__ import annotations

import datetime as dt
import os
import socket
import uuid
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from sqlalchemy import func, select, update

from romams import serialize
from romams.persistence.codec import iso
from romams.persistence.models import Job, utcnow
from romams.persistence.repository import Repository
from romams.persistence.status import ACTIVE, FINAL, JobStatus, values

_ACTIVE = values(ACTIVE)
_RUNNING = (JobStatus.RUNNING.value,)
EVENTS_MAX = 50  # progress messages kept per job


def job_dict(job: Job) -> dict[str, Any]:
    """API view of a job row (the status as its plain text)."""
    return {
        "id": job.id,
        "kind": job.kind,
        "status": job.status,
        "progress": float(job.progress),
        "message": job.message,
        "result": job.result,
        "error": job.error,
        "params": job.params,
        "wing_id": job.wing_id,
        "parent_id": job.parent_id,
        "deliveries": job.deliveries,
        "worker": job.worker,
        "run_id": job.run_id,
        "traceback": job.traceback,
        "events": job.events or [],
        "created_at": iso(job.created_at),
        "started_at": iso(job.started_at),
        "finished_at": iso(job.finished_at),
        "updated_at": iso(job.updated_at),
    }


class JobRepository(Repository):
    """Create, read and transition job rows."""

    # ---- create and read ---------------------------------------------------------------------
    def create(self, kind: str, params: Mapping[str, Any], *, wing_id: int | None = None, key: str | None = None,
               parent_id: str | None = None, job_id: str | None = None, message: str = "queued",
               stage: str | None = None, run_id: int | None = None) -> str:
        """Insert a queued job row; returns its id (send its message only after the unit of work committed)."""
        jid = job_id or str(uuid.uuid4())
        now = utcnow()
        self._session.add(Job(id=jid, kind=kind, status=JobStatus.QUEUED.value, progress=0.0, message=message,
                              params=serialize.to_jsonable(dict(params)), wing_id=wing_id, key=key,
                              parent_id=parent_id, deliveries=0, stage=stage, run_id=run_id, created_at=now,
                              updated_at=now))
        self._session.flush()
        return jid

    def get(self, job_id: str) -> dict[str, Any] | None:
        """Job row as a dict, or None."""
        job = self._session.get(Job, job_id, populate_existing=True)
        return None if job is None else job_dict(job)

    def status(self, job_id: str) -> JobStatus | None:
        """Just the status of a job (cheap poll), or None."""
        status = self._session.scalar(select(Job.status).where(Job.id == job_id))
        return None if status is None else JobStatus(status)

    def stage(self, job_id: str) -> str | None:
        """The fan-out stage of a job (None, "fanout" or "finalize"); None also for an absent job."""
        return self._session.scalar(select(Job.stage).where(Job.id == job_id))

    def children(self, parent_id: str) -> list[dict[str, Any]]:
        """Child jobs of a fan-out job, oldest first."""
        rows = self._session.scalars(select(Job).where(Job.parent_id == parent_id).order_by(Job.created_at, Job.id)
                                     .execution_options(populate_existing=True))
        return [job_dict(j) for j in rows]

    def fan_out(self, parent_id: str, kind: str, params: Sequence[Mapping[str, Any]], *,
                wing_id: int | None = None) -> list[dict[str, Any]] | None:
        """Children of a running fan-out job, created once (a re-delivery finds the first ones); None if the
        parent is no longer running. The guarded write on the parent comes first, so a concurrent cancel either
        lands before (no child is created) or waits for this unit of work and then finds the children."""
        if not self.heartbeat(parent_id):
            return None
        if not self.children(parent_id):
            for p in params:
                self.create(kind, p, wing_id=wing_id, parent_id=parent_id)
        return self.children(parent_id)

    def recent(self, limit: int = 50, status: JobStatus | str | None = None, kind: str | None = None,
               parent_id: str | None = None, top_level: bool = False, *, wing_id: int | None = None,
               run_id: int | None = None, include_runs: bool = True, offset: int = 0) -> list[dict[str, Any]]:
        """Newest jobs first, optionally filtered by status, kind, parent, wing or run (``include_runs=False``:
        without the batches of runs, unless ``run_id`` is given); ``offset`` skips the newest ones (pagination)."""
        q = self._filtered(status, kind, parent_id, top_level, wing_id, run_id, include_runs)
        q = (q.order_by(Job.created_at.desc(), Job.id).offset(int(offset)).limit(int(limit))
             .execution_options(populate_existing=True))
        return [job_dict(j) for j in self._session.scalars(q)]

    def count(self, status: JobStatus | str | None = None, kind: str | None = None, top_level: bool = False, *,
              wing_id: int | None = None, run_id: int | None = None, include_runs: bool = True) -> int:
        """Number of jobs matching the filters of :meth:`recent`."""
        q = self._filtered(status, kind, None, top_level, wing_id, run_id, include_runs)
        return int(self._session.scalar(select(func.count()).select_from(q.subquery())) or 0)

    @staticmethod
    def _filtered(status: JobStatus | str | None, kind: str | None, parent_id: str | None, top_level: bool,
                  wing_id: int | None, run_id: int | None, include_runs: bool) -> Any:
        """SELECT of the jobs matching the filters."""
        q = select(Job)
        if status:
            q = q.where(Job.status == JobStatus(status).value)
        if kind:
            q = q.where(Job.kind == kind)
        if parent_id:
            q = q.where(Job.parent_id == parent_id)
        if top_level:
            q = q.where(Job.parent_id.is_(None))
        if wing_id is not None:
            q = q.where(Job.wing_id == int(wing_id))
        if run_id is not None:
            q = q.where(Job.run_id == int(run_id))
        elif not include_runs:
            q = q.where(Job.run_id.is_(None))
        return q

    def active_of_run(self, run_id: int) -> int:
        """Number of queued or running jobs of a run."""
        return int(self._session.scalar(select(func.count(Job.id)).where(Job.run_id == int(run_id),
                                                                          Job.status.in_(_ACTIVE))) or 0)

    def find_active(self, key: str) -> dict[str, Any] | None:
        """Newest queued or running job with this dedupe key, or None."""
        job = self._session.scalar(select(Job).where(Job.key == key, Job.status.in_(_ACTIVE))
                                   .order_by(Job.created_at.desc()).execution_options(populate_existing=True))
        return None if job is None else job_dict(job)

    def stale(self, older_than_s: float, status: JobStatus = JobStatus.RUNNING) -> list[dict[str, Any]]:
        """Jobs in ``status`` whose row has not been touched for ``older_than_s`` seconds: running ones whose worker
        died, or queued ones whose message may be lost (a broker restart without persistence, a delivery that
        failed before its row could be read)."""
        cutoff = utcnow() - dt.timedelta(seconds=float(older_than_s))
        if self._session.get_bind().dialect.name == "sqlite":
            cutoff = cutoff.replace(tzinfo=None)
        q = select(Job).where(Job.status == JobStatus(status).value, Job.updated_at < cutoff)
        return [job_dict(j) for j in self._session.scalars(q.execution_options(populate_existing=True))]

    # ---- transitions -------------------------------------------------------------------------
    def update(self, job_id: str, expect: Iterable[JobStatus | str] | None = None, **changes: Any) -> bool:
        """Guarded UPDATE of a job (only when its status is in ``expect``); True if a row changed."""
        changes = dict(changes)
        if "status" in changes:
            changes["status"] = JobStatus(changes["status"]).value
        if "result" in changes and changes["result"] is not None:
            changes["result"] = serialize.to_jsonable(changes["result"])
        for text_col in ("message", "error", "traceback"):  # texts may quote an input; PostgreSQL text cannot hold NUL
            if isinstance(changes.get(text_col), str):
                changes[text_col] = changes[text_col].replace("\x00", "\\0")
        changes["updated_at"] = utcnow()
        q = update(Job).where(Job.id == job_id)
        if expect is not None:
            q = q.where(Job.status.in_(values(tuple(expect))))
        return self._session.execute(q.values(**changes)).rowcount > 0

    def start(self, job_id: str, max_deliveries: int) -> tuple[bool, int]:
        """Mark a delivery: queued|running -> running, deliveries += 1; (ok, deliveries) with ok False when the
        job is final, absent or over the redelivery cap (then it is failed with the reason)."""
        now = utcnow()
        where = f"{socket.gethostname()}:{os.getpid()}"
        n = self._session.execute(
            update(Job).where(Job.id == job_id, Job.status.in_(_ACTIVE))
            .values(status=JobStatus.RUNNING.value, deliveries=Job.deliveries + 1, worker=where,
                    started_at=func.coalesce(Job.started_at, now), updated_at=now)).rowcount
        deliveries = int(self._session.scalar(select(Job.deliveries).where(Job.id == job_id)) or 0)
        if n == 0:
            return False, deliveries
        if deliveries > max_deliveries:
            self.finish(job_id, JobStatus.FAILED,
                        error=f"job delivered {deliveries} times (cap {max_deliveries}): its worker kept dying")
            return False, deliveries
        return True, deliveries

    def claim(self, job_id: str, max_deliveries: int) -> dict[str, Any] | None:
        """``start`` and read the row in one statement (UPDATE ... RETURNING): the job dict, or None when the job is
        final, absent or over the redelivery cap (then it is failed with the reason)."""
        now = utcnow()
        where = f"{socket.gethostname()}:{os.getpid()}"
        job = self._session.scalars(
            update(Job).where(Job.id == job_id, Job.status.in_(_ACTIVE))
            .values(status=JobStatus.RUNNING.value, deliveries=Job.deliveries + 1, worker=where,
                    started_at=func.coalesce(Job.started_at, now), updated_at=now)
            .returning(Job).execution_options(synchronize_session=False)).one_or_none()
        if job is None:
            return None
        if job.deliveries > max_deliveries:
            self.finish(job_id, JobStatus.FAILED,
                        error=f"job delivered {job.deliveries} times (cap {max_deliveries}): its worker kept dying")
            return None
        return job_dict(job)

    def progress(self, job_id: str, fraction: float, message: str = "") -> bool:
        """Progress 0..1 with a message, only while running; False if the job is no longer running. A new message
        is appended to the job's progress history (the last ``EVENTS_MAX`` are kept)."""
        fraction = float(min(max(fraction, 0.0), 1.0))
        message = message[:2000]
        events = self._session.scalar(select(Job.events).where(Job.id == job_id)) or []
        changes: dict[str, Any] = {"progress": fraction, "message": message}
        if message and (not events or events[-1][2] != message):
            changes["events"] = [*events[-(EVENTS_MAX - 1):], [iso(utcnow()), round(fraction, 4), message[:200]]]
        return self.update(job_id, expect=_RUNNING, **changes)

    def finish(self, job_id: str, status: JobStatus | str, result: Any = None, error: str | None = None,
               message: str | None = None, traceback: str | None = None) -> bool:
        """Final transition from queued/running to succeeded/failed/cancelled (guarded)."""
        if status not in FINAL:
            raise ValueError(f"status: {status!r} is not a final status")
        status = JobStatus(status)
        changes: dict[str, Any] = {"status": status, "finished_at": utcnow()}
        if status is JobStatus.SUCCEEDED:
            changes["progress"] = 1.0
        changes["message"] = message if message is not None else status.value
        if result is not None:
            changes["result"] = result
        if error is not None:
            changes["error"] = error[:20000]
        if traceback is not None:
            changes["traceback"] = traceback[:20000]
        return self.update(job_id, expect=ACTIVE, **changes)

    def cancel(self, job_id: str) -> bool:
        """Cancel a queued or running job and its active children; True if the job itself changed."""
        ok = self.finish(job_id, JobStatus.CANCELLED, message="cancelled by request")
        children = self._session.scalars(select(Job.id).where(Job.parent_id == job_id, Job.status.in_(_ACTIVE))).all()
        for c in children:
            self.finish(c, JobStatus.CANCELLED, message="parent cancelled")
        return ok

    def claim_stage(self, job_id: str, expect: str | None, new: str) -> bool:
        """Atomically move a job's stage from ``expect`` to ``new``; True for exactly one caller."""
        q = update(Job).where(Job.id == job_id, Job.stage.is_(None) if expect is None else Job.stage == expect)
        return self._session.execute(q.values(stage=new, updated_at=utcnow())).rowcount > 0

    def heartbeat(self, job_id: str) -> bool:
        """Touch updated_at of a running job (proof of life for the stale-job sweeper)."""
        return self.update(job_id, expect=_RUNNING)

    def touch_queued(self, job_id: str, message: str) -> bool:
        """Touch a queued job (guarded) before its message is sent again; True if it was still queued."""
        return self.update(job_id, expect=(JobStatus.QUEUED.value,), message=message)

    def requeue(self, job_id: str, message: str) -> bool:
        """running -> queued (guarded), before a stale job's message is sent again."""
        return self.update(job_id, expect=_RUNNING, status=JobStatus.QUEUED, message=message)
