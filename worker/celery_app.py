"""The Celery application of the workers: the service's queue configuration plus the task bodies.

Queues: ``training`` (long: basis and ROM training work) and ``evaluation`` (short: flutter
evaluations). Reliability: late acknowledgement, reject-on-worker-lost (a task whose process dies is
requeued), prefetch 1, and a redelivery cap counted in the job row. The configuration lives in the
service layer (``romams.services.queue``) so that the API can send tasks without importing this package.
The same tasks run embedded (SQLite + kombu's SQLAlchemy transport on a SQLite file, no server)
and distributed (Redis broker + PostgreSQL).
"""

from __future__ import annotations

import os
from typing import Any

# One BLAS thread per worker process: the pool already runs one process per core, and oversubscribed
# OpenBLAS threads make small dense eigenproblems several times slower. Set before numpy is imported.
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

from celery import Task  # noqa: E402
from celery.signals import worker_init, worker_process_init  # noqa: E402

from romams.persistence import DatabaseUnavailable  # noqa: E402
from romams.services.queue import EVALUATION_QUEUE, TRAINING_QUEUE, celery_config, make_celery  # noqa: E402
from romams.settings import Settings, get_settings  # noqa: E402

TASK_MODULES = ["worker.tasks", "worker.evaluation"]


class RetryOnDatabaseOutage(Task):
    """Base of the service's tasks: a task that meets an unavailable database (at its start, or while it runs) is
    retried with the same task id after a growing countdown (1, 2, 4 ... 30 s, for about 10 minutes) instead of
    being acknowledged with its job row left behind; after that the stale-job sweeper takes over."""

    autoretry_for = (DatabaseUnavailable,)
    retry_backoff = 1
    retry_backoff_max = 30
    retry_jitter = True
    max_retries = 25


def make_app(settings: Settings | None = None) -> Any:
    """The workers' Celery app for ``settings`` with the service's tasks registered."""
    return make_celery(settings or get_settings(), include=TASK_MODULES, task_cls=RetryOnDatabaseOutage)


app = make_app()


@worker_init.connect
def _compile_kernels(**_: Any) -> None:
    """Compile (or load from numba's cache) the flutter tracker's kernels in the main process, before the pool
    forks: no evaluation waits for a compilation."""
    from romams_core.flutter.newton_kernel import warm_up

    warm_up()


@worker_process_init.connect
def _fresh_connections(**_: Any) -> None:
    """A forked pool process must not reuse the parent's database connections."""
    from romams.persistence import dispose_engines

    dispose_engines()
    from worker import context

    context.reset_process_state()


__all__ = ["EVALUATION_QUEUE", "TRAINING_QUEUE", "app", "celery_config", "make_app"]
