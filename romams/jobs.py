"""Job state helpers shared by the API and the workers.

The job row is the source of truth. Submitting commits the row first and sends the Celery message
after (with the row id as the task id). A task runs inside :func:`run_job`: a guarded start that
counts deliveries (over the cap the job fails with the reason), a heartbeat thread that touches the
row while the task is alive, a progress callback that raises ``Cancelled`` once the job was cancelled,
and a guarded final transition. A job whose result is stored (a basis, a ROM, an evaluation) stores it and
succeeds in one guarded transaction (:func:`store_and_finish`). :func:`sweep_stale` re-sends running jobs whose
worker died and queued jobs whose message may be lost.
"""

from __future__ import annotations

import os
import re
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import anyio
import anyio.to_thread

from romams.periodic import Periodic
from romams.persistence import FINAL, DatabaseUnavailable, JobStatus, Store, UnitOfWork
from romams.services.errors import error_dict
from romams.services.queue import FINALIZE_FOR_KIND, TASK_FOR_KIND

try:  # the core's cancellation exception, raised by progress callbacks and passed through by solvers
    from romams_core.aero.protocol import Cancelled
except ImportError:  # pragma: no cover - the protocol module is part of the core

    class Cancelled(Exception):  # type: ignore[no-redef]
        """Raised to abort a cancelled job."""


ProgressFn = Callable[[float, str], None]
#: the directory holding the project's packages: traceback file names are shown relative to it
PROJECT_ROOT = str(Path(__file__).resolve().parents[1]) + os.sep
_FILE = re.compile(r'File "([^"]+)"')


def format_traceback(limit: int = 12) -> str:
    """The traceback of the exception being handled, file names relative to the project (or to site-packages), so
    that a stored job shows no path of the worker's machine."""

    def short(m: re.Match[str]) -> str:
        path = m.group(1)
        if path.startswith(PROJECT_ROOT):
            path = path[len(PROJECT_ROOT):]
        elif "site-packages" + os.sep in path:
            path = path.split("site-packages" + os.sep, 1)[1]
        return f'File "{path}"'

    return _FILE.sub(short, traceback.format_exc(limit=limit))


class JobFailed(Exception):
    """A job failure with a user-facing reason (stored as the job's error text)."""


@dataclass(frozen=True)
class Outcome:
    """How a task's job ended: its final status, the body's result and the structured error (if failed)."""

    status: str | None  # succeeded | failed | cancelled, None when the job was not run (final, absent, over cap)
    result: Any = None
    error: dict[str, Any] | None = None

    def as_dict(self) -> dict[str, Any]:
        """JSON form returned through the result backend."""
        return {"status": None if self.status is None else str(self.status), "result": self.result,
                "error": self.error}


class BrokerUnavailable(RuntimeError):
    """The task message could not be sent (the job row was marked failed)."""


def send(celery: Any, task_name: str, job_id: str, store: Store | None = None) -> None:
    """Send the message for a committed job row (task id = job id); if the broker refuses, fail the row."""
    try:
        celery.send_task(task_name, args=[job_id], task_id=job_id)
    except Exception as exc:
        if store is not None:
            store.jobs.finish(job_id, JobStatus.FAILED,
                              error=f"could not enqueue the task: {type(exc).__name__}: {exc}")
        raise BrokerUnavailable(f"broker: could not enqueue the task ({type(exc).__name__}: {exc})") from exc


def submit(store: Store, celery: Any, kind: str, params: dict[str, Any], *, wing_id: int | None = None,
           key: str | None = None, parent_id: str | None = None, stage: str | None = None,
           send_now: bool = True) -> str:
    """Create the job row (committed) and then send its task; returns the job id."""
    job_id = store.jobs.create(kind, params, wing_id=wing_id, key=key, parent_id=parent_id, stage=stage)
    if send_now:
        send(celery, TASK_FOR_KIND[kind], job_id, store)
    return job_id


def _collect(celery: Any, res: Any, timeout_s: float) -> dict[str, Any] | None:
    """The outcome dict of ``res`` (waiting at most ``timeout_s``; None on timeout); a database backend's copy is
    dropped once read (the Redis one expires by itself, ``result_expires_s``)."""
    from celery.exceptions import TimeoutError as CeleryTimeout

    try:
        out = res.get(timeout=timeout_s, interval=0.005, propagate=False, disable_sync_subtasks=False)
    except CeleryTimeout:
        return None
    if not str(celery.conf.result_backend).startswith(("redis", "rediss")):
        try:  # the database backend keeps results until a cleanup task runs: drop this one now
            res.forget()
        except Exception:  # noqa: BLE001 - a backend that cannot forget keeps the result until it expires
            pass
    return out if isinstance(out, dict) else None


async def wait_result_async(celery: Any, job_id: str, timeout_s: float, poll_s: float = 0.005,
                            max_poll_s: float = 0.025) -> dict[str, Any] | None:
    """The outcome dict a task returned through the result backend (None after ``timeout_s``); nothing polls the
    jobs table, and no thread is held while it waits: the backend's state is read on a worker thread (one short
    read), every ``poll_s`` growing to ``max_poll_s`` seconds, and the event loop sleeps in between."""
    res = celery.AsyncResult(job_id)
    deadline = time.monotonic() + timeout_s
    delay = poll_s
    while not await anyio.to_thread.run_sync(res.ready):
        left = deadline - time.monotonic()
        if left <= 0:
            return None
        await anyio.sleep(min(delay, left))
        delay = min(delay * 1.5, max_poll_s)
    return await anyio.to_thread.run_sync(_collect, celery, res, 5.0)


async def wait_for_async(store: Store, job_id: str, timeout_s: float, poll_s: float = 0.01) -> dict[str, Any] | None:
    """Poll a job row until it is final: the final job dict, or None after ``timeout_s``; no thread is held
    between the reads of the row."""
    deadline = time.monotonic() + timeout_s
    delay = poll_s
    while True:
        status = await anyio.to_thread.run_sync(store.jobs.status, job_id)
        if status in FINAL:
            return await anyio.to_thread.run_sync(store.jobs.get, job_id)
        if status is None or time.monotonic() > deadline:
            return None
        await anyio.sleep(delay)
        delay = min(delay * 1.5, 0.05)


class _Heartbeat:
    """Background thread touching a running job row every ``period_s`` seconds (ends when the job is not ours)."""

    def __init__(self, store: Store, job_id: str, period_s: float) -> None:
        jobs = store.jobs

        def beat() -> bool:
            return bool(jobs.heartbeat(job_id) or jobs.update(job_id, expect=(JobStatus.QUEUED,),
                                                               status=JobStatus.RUNNING))

        self._thread = Periodic(beat, period_s, "romams-heartbeat")

    def __enter__(self) -> _Heartbeat:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._thread.stop()


def progress_callback(store: Store, job_id: str, lo: float = 0.0, hi: float = 1.0,
                      min_interval_s: float = 0.2) -> ProgressFn:
    """Progress reporter mapping 0..1 onto lo..hi of the job; raises Cancelled when the job is no longer running."""
    last = [0.0]

    def still_mine() -> None:
        """Raise Cancelled unless the job is running; a job the sweeper re-queued while we live is taken back."""
        status = store.jobs.status(job_id)
        if status == JobStatus.QUEUED and store.jobs.update(job_id, expect=(JobStatus.QUEUED,),
                                                            status=JobStatus.RUNNING):
            return
        if status != JobStatus.RUNNING:
            raise Cancelled(f"job {job_id} is {status}")

    def report(fraction: float, message: str = "") -> None:
        now = time.monotonic()
        if now - last[0] < min_interval_s and fraction < 1.0:
            still_mine()
            return
        last[0] = now
        if not store.jobs.progress(job_id, lo + (hi - lo) * float(fraction), message):
            still_mine()
            store.jobs.progress(job_id, lo + (hi - lo) * float(fraction), message)

    return report


def store_and_finish(store: Store, job_id: str, save: Callable[[UnitOfWork], dict[str, Any]]) -> dict[str, Any]:
    """Store what a job produced and mark it succeeded in one transaction, guarded: ``save(uow)`` writes the
    result rows and returns the job's result; the job then moves to ``succeeded`` only if it is still queued or
    running. If it is not (cancelled meanwhile, or finished by another delivery), the transaction is rolled back
    and ``Cancelled`` is raised: a cancelled job stores nothing, and a stored model belongs to a succeeded job."""
    with store.unit_of_work() as uow:
        result = save(uow)
        if not uow.jobs.finish(job_id, JobStatus.SUCCEEDED, result=result, message="done"):
            raise Cancelled(f"job {job_id} is {uow.jobs.status(job_id)}: its result was not stored")
    return result


def end_cancelled(store: Store, job_id: str) -> None:
    """A job whose body stopped on ``Cancelled``: cancelled, and if it is (not finished by another delivery), so
    are its active children: a fan-out parent that created its chunks after the cancel leaves none queued."""
    with store.unit_of_work() as uow:
        uow.jobs.finish(job_id, JobStatus.CANCELLED, message="cancelled")
        if uow.jobs.status(job_id) == JobStatus.CANCELLED:
            uow.jobs.cancel(job_id)


def run_job(store: Store, job_id: str, body: Callable[[dict[str, Any], ProgressFn], Any], *, max_deliveries: int,
            heartbeat_s: float, count_delivery: bool = True, finish: bool = True,
            reply: Callable[[Outcome], None] | None = None) -> Outcome:
    """Run ``body(job, progress)`` for a job row with guarded start/finish; returns the Outcome.

    A failure stores the error text, its traceback and, as the job's result, the structured error ``{"error":
    {status, field, detail, reason}}`` (typed errors keep their field from the core to the HTTP problem).
    ``reply(outcome)`` (a synchronous caller waiting on the result backend) is called as soon as the body has
    succeeded, before the final row update, so the answer does not wait for the bookkeeping.
    """
    with store.unit_of_work() as uow:  # start (or check) and read the row in one transaction
        if count_delivery:
            job = uow.jobs.claim(job_id, max_deliveries)
        else:
            job = uow.jobs.get(job_id)
            job = job if job is not None and job["status"] == JobStatus.RUNNING else None
    if job is None:
        return Outcome(None)
    try:
        with _Heartbeat(store, job_id, heartbeat_s):
            result = body(job, progress_callback(store, job_id))
    except Cancelled:
        end_cancelled(store, job_id)
        return Outcome(JobStatus.CANCELLED)
    except DatabaseUnavailable:  # transient, not the job's fault: the row stays as it is for a retry or the sweeper
        raise
    except (ValueError, KeyError, JobFailed) as exc:
        err = error_dict(exc) if isinstance(exc, ValueError) else {"status": 500, "field": None,
                                                                    "detail": str(exc), "reason": str(exc)}
        store.jobs.finish(job_id, JobStatus.FAILED, error=f"{type(exc).__name__}: {exc}", message="failed",
                          result={"error": err}, traceback=format_traceback())
        return Outcome(JobStatus.FAILED, error=err)
    except Exception as exc:  # noqa: BLE001 - every failure must end in a final job state
        tb = traceback.format_exc(limit=8)
        name = type(exc).__name__
        reason = "time limit exceeded" if name in ("SoftTimeLimitExceeded", "TimeLimitExceeded") else str(exc)
        store.jobs.finish(job_id, JobStatus.FAILED, error=f"{name}: {reason}\n{tb}", message="failed",
                          traceback=format_traceback())
        return Outcome(JobStatus.FAILED, error={"status": 500, "field": None, "detail": f"{name}: {reason}",
                                                "reason": reason})
    outcome = Outcome(JobStatus.SUCCEEDED, result)
    if reply is not None:
        try:
            reply(outcome)
        except Exception:  # noqa: BLE001 - the answer also goes out when the task returns
            pass
    if finish:
        store.jobs.finish(job_id, JobStatus.SUCCEEDED, result=result, message="done")
    return outcome


def fanout_outcome(store: Store, parent_id: str) -> list[dict[str, Any]] | None:
    """The chunks of a fan-out parent, or None after ending the parent because a chunk was cancelled or failed."""
    kids = store.jobs.children(parent_id)
    if any(k["status"] == JobStatus.CANCELLED for k in kids):
        store.jobs.finish(parent_id, JobStatus.CANCELLED, message="a chunk was cancelled")
        return None
    failed = [k for k in kids if k["status"] == JobStatus.FAILED]
    if failed:
        first = failed[0]
        store.jobs.finish(parent_id, JobStatus.FAILED,
                          error=f"chunk {first['params'].get('index')} failed: {first['error']}",
                          traceback=first.get("traceback"))
        return None
    return kids


def _sweep_fanout(store: Store, celery: Any, job: dict[str, Any]) -> bool:
    """A fan-out parent: keep it alive while its chunks work; end or finalize it once they all ended (the last
    chunk's own hand-over may have been lost to a database outage). True when a finalize task was sent."""
    kids = fanout_outcome(store, job["id"])
    if kids is None:
        return False
    task = FINALIZE_FOR_KIND.get(job["kind"])
    if kids and task and all(k["status"] == JobStatus.SUCCEEDED for k in kids) \
            and store.jobs.claim_stage(job["id"], "fanout", "finalize"):
        store.jobs.heartbeat(job["id"])
        celery.send_task(task, args=[job["id"]])
        return True
    store.jobs.heartbeat(job["id"])  # its chunks carry the work; they are swept on their own
    return False


def sweep_stale(store: Store, celery: Any, stale_s: float, queued_resend_s: float | None = None) -> list[str]:
    """Re-send running jobs untouched for ``stale_s`` seconds (their worker died) and queued jobs untouched for
    ``queued_resend_s`` seconds (their message may be lost: a broker restart without persistence, a task that
    failed before it could read its row); returns their ids. A duplicate message is harmless: the guarded start
    lets one delivery run the job and the others return."""
    resent = []
    for job in store.jobs.stale(stale_s):
        kind, stage = job["kind"], store.jobs.stage(job["id"])
        if stage == "fanout":
            if _sweep_fanout(store, celery, job):
                resent.append(job["id"])
            continue
        task = FINALIZE_FOR_KIND.get(kind) if stage == "finalize" else TASK_FOR_KIND.get(kind)
        if task is None:
            continue
        if stage == "finalize":
            store.jobs.heartbeat(job["id"])
            celery.send_task(task, args=[job["id"]])
        elif store.jobs.requeue(job["id"], f"re-sent after {stale_s:.0f} s without a heartbeat (worker lost)"):
            celery.send_task(task, args=[job["id"]], task_id=job["id"])
        resent.append(job["id"])
    if queued_resend_s is not None:
        for job in store.jobs.stale(queued_resend_s, status=JobStatus.QUEUED):
            task = TASK_FOR_KIND.get(job["kind"])
            if task and store.jobs.touch_queued(job["id"], f"re-sent after {queued_resend_s:.0f} s in the queue "
                                                           "(its message may have been lost)"):
                celery.send_task(task, args=[job["id"]], task_id=job["id"])
                resent.append(job["id"])
    return resent


class StaleSweeper(Periodic):
    """Daemon thread calling :func:`sweep_stale` periodically (runs in the API process)."""

    def __init__(self, store: Store, celery: Any, stale_s: float, period_s: float | None = None,
                 queued_resend_s: float | None = None) -> None:
        self.store, self.celery, self.stale_s, self.queued_resend_s = store, celery, stale_s, queued_resend_s
        super().__init__(self._sweep, period_s or max(1.0, stale_s / 4), "romams-stale-sweeper")

    def _sweep(self) -> None:
        sweep_stale(self.store, self.celery, self.stale_s, self.queued_resend_s)
