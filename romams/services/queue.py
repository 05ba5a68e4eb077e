"""Queue configuration of the service: Celery settings, queue names, task names and the task sender.

The API only *sends* tasks (by name) and waits for short results; the worker package registers the task
bodies on an app built from the same configuration (``worker.celery_app``). Keeping the configuration here
lets the API talk to the queue without importing the worker package.

Results of short tasks (a synchronous flutter evaluation) come back through a Celery result backend
instead of a database poll: Redis (publish/subscribe, no polling) when the broker is Redis, else the
database backend on a SQLite file next to the embedded broker (the embedded mode has no server that
could push a notification).
"""

from __future__ import annotations

from typing import Any

from kombu import Exchange, Queue

from romams.settings import Settings, get_settings

TRAINING_QUEUE = "training"
EVALUATION_QUEUE = "evaluation"

#: task name that runs a job of each kind (the stale-job sweeper re-sends by kind)
TASK_FOR_KIND = {
    "basis": "romams.training.basis",
    "basis-chunk": "romams.training.basis_chunk",
    "training": "romams.training.rom",
    "flutter": "romams.evaluation.flutter",
    "flutter-chunk": "romams.evaluation.flutter_chunk",
    "flutter-pms": "romams.training.flutter_pms",
}
FINALIZE_FOR_KIND = {"basis": "romams.training.basis_finalize", "flutter-batch": "romams.evaluation.batch_finalize"}


def result_backend(settings: Settings) -> str:
    """Celery result backend URL for ``settings`` (explicit setting, else Redis or a SQLite results file)."""
    if settings.result_backend_url:
        return settings.result_backend_url
    broker = settings.broker
    if broker.startswith(("redis://", "rediss://")):
        return broker
    settings.data_dir.mkdir(parents=True, exist_ok=True)
    return f"db+sqlite:///{settings.data_dir.resolve() / 'results.db'}"


def celery_config(settings: Settings) -> dict[str, Any]:
    """Celery configuration for ``settings`` (shared by the task sender and the worker app)."""
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
    backend = result_backend(settings)
    extra: dict[str, Any] = {}
    if backend.startswith("db+sqlite"):
        extra["database_engine_options"] = {"connect_args": {"timeout": 60}}
    return {
        "broker_url": broker,
        "broker_transport_options": transport,
        "broker_connection_retry_on_startup": True,
        "result_backend": backend,
        "result_expires": settings.result_expires_s,
        "task_ignore_result": True,  # only the synchronous evaluation task stores a result (per task)
        "result_extended": False,
        "task_acks_late": True,
        "task_reject_on_worker_lost": True,
        "worker_prefetch_multiplier": 1,
        "task_serializer": "json",
        "result_serializer": "json",
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
        **extra,
    }


def make_celery(settings: Settings | None = None, include: list[str] | None = None, task_cls: Any = None) -> Any:
    """A Celery app for ``settings``; the API uses it (no tasks) to send tasks by name and read results, the
    workers with their task modules (``include``) and base task class (``task_cls``)."""
    from celery import Celery

    settings = settings or get_settings()
    celery = Celery("romams", include=include or [], task_cls=task_cls)
    celery.conf.update(celery_config(settings))
    return celery


def declare_queues(settings: Settings | None = None) -> None:
    """Declare the service's queues on the broker once (for the embedded SQLite broker this creates its tables and
    queue rows), so that processes starting together do not race to create them."""
    celery = make_celery(settings)
    with celery.connection_for_write() as conn:
        channel = conn.default_channel
        for queue in celery.conf.task_queues:
            queue(channel).declare()
