"""The stale-job sweeper: queued jobs whose message was lost are re-sent, and a fan-out parent whose chunks all
ended is finalized (or ended) instead of being kept alive forever, on SQLite and (``services``) on PostgreSQL.

The sweeper's logic runs on a real store; the messages it sends are recorded (``SentTasks``). The loss of real
messages in a real broker is in tests/service/test_distributed.py.
"""

from __future__ import annotations

import time

import pytest

from romams.jobs import sweep_stale
from romams.persistence import JobStatus, open_store

from .conftest import BACKENDS, SentTasks, backend_settings


@pytest.fixture(params=BACKENDS)
def store(request, tmp_path):
    """A fresh store at head (SQLite, or PostgreSQL with the services marker)."""
    return open_store(backend_settings(request, tmp_path), migrate=True)


def test_queued_jobs_are_resent_once_per_period(store):
    with store.unit_of_work() as uow:
        old = uow.jobs.create("training", {"mach": 0.8})
        done = uow.jobs.create("training", {"mach": 0.9})
    store.jobs.finish(done, JobStatus.SUCCEEDED, result={}, message="done")
    time.sleep(1.2)
    with store.unit_of_work() as uow:
        fresh = uow.jobs.create("training", {"mach": 0.85})
    sent = SentTasks()
    resent = sweep_stale(store, sent, stale_s=3600.0, queued_resend_s=1.0)
    assert resent == [old]  # not the one just created, not a finished one
    assert sent.sent == [("romams.training.rom", [old], old)]
    assert store.jobs.get(old)["status"] == JobStatus.QUEUED and "re-sent" in store.jobs.get(old)["message"]
    assert sweep_stale(store, sent, stale_s=3600.0, queued_resend_s=1.0) == []  # touched: not again at once
    assert fresh not in resent
    assert sweep_stale(store, SentTasks(), stale_s=3600.0) == []  # without the setting, queued jobs are left alone


def _fanout(store, kind: str, child_kind: str, n: int) -> tuple[str, list[str]]:
    """A running fan-out parent (stage "fanout") with n queued chunks."""
    with store.unit_of_work() as uow:
        parent = uow.jobs.create(kind, {"samples": n})
        kids = [uow.jobs.create(child_kind, {"index": i}, parent_id=parent) for i in range(n)]
    assert store.jobs.start(parent, 5)[0]
    assert store.jobs.claim_stage(parent, None, "fanout")
    return parent, kids


def test_fanout_parent_is_finalized_when_its_chunks_ended(store):
    parent, kids = _fanout(store, "basis", "basis-chunk", 2)
    for k in kids:
        store.jobs.finish(k, JobStatus.SUCCEEDED, result={}, message="done")
    time.sleep(0.05)
    sent = SentTasks()
    assert sweep_stale(store, sent, stale_s=0.03) == [parent]  # the last chunk's hand-over was lost
    assert sent.sent == [("romams.training.basis_finalize", [parent], None)]
    assert store.jobs.stage(parent) == "finalize"
    time.sleep(0.05)
    sent2 = SentTasks()
    sweep_stale(store, sent2, stale_s=0.03)  # a finalize that stalls is sent again, not claimed twice
    assert sent2.sent == [("romams.training.basis_finalize", [parent], None)]


def test_fanout_parent_is_kept_alive_while_chunks_work_and_ends_with_a_failed_chunk(store):
    parent, kids = _fanout(store, "flutter-batch", "flutter-chunk", 2)
    store.jobs.finish(kids[0], JobStatus.SUCCEEDED, result={}, message="done")
    time.sleep(0.05)
    sent = SentTasks()
    assert sweep_stale(store, sent, stale_s=0.03) == [] and sent.sent == []
    assert store.jobs.get(parent)["status"] == JobStatus.RUNNING
    store.jobs.finish(kids[1], JobStatus.FAILED, error="boom", message="failed")
    time.sleep(0.05)
    assert sweep_stale(store, sent, stale_s=0.03) == []
    job = store.jobs.get(parent)
    assert job["status"] == JobStatus.FAILED and "chunk 1 failed" in job["error"]


def test_a_parent_cancelled_before_its_chunks_exist_cancels_them_when_it_stops(store):
    """The cancel races the fan-out: it lands before the parent's chunk rows are committed (so it cannot cancel
    them), and the parent's next progress step stops it; the chunks it created end cancelled, none is queued."""
    from romams.jobs import run_job

    parent = store.jobs.create("basis", {"samples": 4})

    def body(job, progress):
        assert store.jobs.cancel(parent)  # no chunk row yet: nothing else to cancel
        with store.unit_of_work() as uow:
            for i in range(2):
                uow.jobs.create("basis-chunk", {"index": i}, parent_id=parent)
        progress(0.02, "2 chunks")
        raise AssertionError("not reached: the progress step of a cancelled job raises")

    assert run_job(store, parent, body, max_deliveries=3, heartbeat_s=5.0).status == JobStatus.CANCELLED
    assert [k["status"] for k in store.jobs.children(parent)] == [JobStatus.CANCELLED] * 2


def test_a_database_outage_in_a_task_leaves_its_row_for_the_retry(store):
    """An unavailable database is not the job's failure: run_job lets it through (the worker retries the task)."""
    from romams.jobs import run_job
    from romams.persistence import DatabaseUnavailable

    job = store.jobs.create("training", {"mach": 0.8})

    def body(job, progress):
        raise DatabaseUnavailable("database: unavailable (test)")

    with pytest.raises(DatabaseUnavailable):
        run_job(store, job, body, max_deliveries=3, heartbeat_s=5.0)
    row = store.jobs.get(job)
    assert row["status"] == JobStatus.RUNNING and row["error"] is None
    assert run_job(store, job, lambda j, p: {"ok": True}, max_deliveries=3, heartbeat_s=5.0).status == "succeeded"
    assert store.jobs.get(job)["deliveries"] == 2


def test_worker_tasks_retry_on_an_unavailable_database():
    import worker.evaluation  # noqa: F401 - registers the tasks
    import worker.tasks  # noqa: F401
    from romams.persistence import DatabaseUnavailable
    from worker.celery_app import app

    for name in ("romams.training.basis", "romams.training.rom", "romams.evaluation.flutter",
                 "romams.evaluation.flutter_chunk", "romams.training.basis_finalize"):
        task = app.tasks[name]
        assert DatabaseUnavailable in task.autoretry_for and task.max_retries >= 10, name
