"""The one Celery application of the service, configured from romams.settings.

Queues: ``training`` (long: basis and ROM training work) and ``evaluation`` (short: flutter
evaluations). Reliability: late acknowledgement, reject-on-worker-lost (a task whose process dies is
requeued), prefetch 1, and a redelivery cap counted in the job row (romams.persistence.jobs.JobRepository.start).
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

from celery import Celery  # noqa: E402
from celery.signals import worker_process_init  # noqa: E402
from kombu import Exchange, Queue  # noqa: E402

from romams.settings import Settings, get_settings  # noqa: E402

TRAINING_QUEUE = "training"
EVALUATION_QUEUE = "evaluation"


def celery_config(settings: Settings) -> dict[str, Any]:
    """Celery configuration for ``settings``."""
    broker = settings.broker
    transport: dict[str, Any] = {}
    if broker.startswith("sqla+"):
        settings.data_dir.mkdir(parents=True, exist_ok=True)
        # kombu's SQLAlchemy transport polls (its options all go to create_engine: only the busy timeout here)
        import kombu.transport.sqlalchemy as sqla_transport

        sqla_transport.Transport.polling_interval = settings.broker_poll_s
        transport = {"connect_args": {"timeout": 60}}
    elif broker.startswith(("redis", "rediss")):
        transport = {"visibility_timeout": settings.broker_visibility_timeout_s}
    return {
        "broker_url": broker,
        "broker_transport_options": transport,
        "broker_connection_retry_on_startup": True,
        "result_backend": None,
        "task_ignore_result": True,
        "task_acks_late": True,
        "task_reject_on_worker_lost": True,
        "worker_prefetch_multiplier": 1,
        "task_serializer": "json",
        "accept_content": ["json"],
        "task_default_queue": TRAINING_QUEUE,
        "task_default_exchange": TRAINING_QUEUE,
        "task_default_routing_key": TRAINING_QUEUE,
        "task_queues": tuple(Queue(q, Exchange(q, type="direct"), routing_key=q)
                             for q in (TRAINING_QUEUE, EVALUATION_QUEUE)),
        "task_routes": {
            "romams.training.*": {"queue": TRAINING_QUEUE},
            "romams.evaluation.*": {"queue": EVALUATION_QUEUE},
        },
        "worker_hijack_root_logger": False,
        "worker_send_task_events": True,
        "task_send_sent_event": True,
    }


def make_app(settings: Settings | None = None) -> Celery:
    """A Celery app for ``settings`` with the service's tasks registered."""
    settings = settings or get_settings()
    celery = Celery("romams", include=["worker.tasks"])
    celery.conf.update(celery_config(settings))
    return celery


app = make_app()


@worker_process_init.connect
def _fresh_connections(**_: Any) -> None:
    """A forked pool process must not reuse the parent's database connections."""
    from romams.persistence import dispose_engines

    dispose_engines()
    from worker import tasks

    tasks.reset_process_state()
