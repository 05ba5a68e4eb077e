"""``romams serve`` (API + an embedded child worker) and ``romams worker`` (a distributed worker)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys

import typer

from romams.cli.app import app


def worker_command(queues: str, concurrency: int, loglevel: str, hostname: str | None = None) -> list[str]:
    """argv of a Celery worker process for the service's app."""
    cmd = [sys.executable, "-m", "celery", "-A", "worker.celery_app", "worker", "-Q", queues,
           "--concurrency", str(concurrency), "--loglevel", loglevel, "--without-gossip", "--without-mingle"]
    if hostname:
        cmd += ["--hostname", hostname]
    return cmd


def _die_with_parent() -> None:
    """In the child (Linux): receive SIGTERM when the parent dies, however it dies (uvicorn re-raises SIGTERM)."""
    try:
        import ctypes

        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


@app.command()
def serve(
    host: str = typer.Option(None, help="bind address (default ROMAMS_HOST or 127.0.0.1)"),
    port: int = typer.Option(None, help="port (default ROMAMS_PORT or 8000)"),
    worker: bool = typer.Option(True, help="start embedded child Celery workers"),
    concurrency: int = typer.Option(None, help="processes per embedded worker (default ROMAMS_WORKER_CONCURRENCY)"),
    split_queues: bool = typer.Option(True, help="one child for training, one for evaluation (evaluations stay "
                                                 "fast while a training runs); else one child for both queues"),
    loglevel: str = typer.Option("warning", help="log level of uvicorn and the workers"),
) -> None:
    """Run the HTTP API and dashboard; by default also child workers on the same (embedded) database and broker."""
    import uvicorn

    from romams.persistence import open_store
    from romams.services.queue import declare_queues
    from romams.settings import get_settings

    settings = get_settings()
    open_store(settings)  # creates the data dir and migrates SQLite before the workers start
    if worker:  # the broker's tables and queues exist before the API and the workers first touch them together
        declare_queues(settings)
    n = concurrency or settings.worker_concurrency
    plan = ([("training", max(1, n // 2), "training@%h"), ("evaluation", n, "evaluation@%h")] if split_queues
            else [("training,evaluation", n, "embedded@%h")])
    children: list[subprocess.Popen] = []
    if worker:
        for queues, procs, name in plan:
            env = dict(os.environ)
            if queues == "evaluation":  # short synchronous evaluations: the embedded broker is polled faster here
                env["ROMAMS_BROKER_POLL_S"] = str(min(settings.broker_poll_s, settings.evaluation_poll_s))
            children.append(subprocess.Popen(worker_command(queues, procs, loglevel, name), env=env,
                                             preexec_fn=_die_with_parent))
            typer.echo(f"embedded worker pid {children[-1].pid}: queues {queues}, {procs} process(es), "
                       f"broker {settings.broker.split('://')[0]}", err=True)
    typer.echo(f"romams API on http://{host or settings.host}:{port or settings.port}/dashboard "
               f"(database {settings.db_url.split(':')[0]})", err=True)
    try:
        uvicorn.run("api.app:app", host=host or settings.host, port=port or settings.port, log_level=loglevel)
    finally:
        for child in children:
            if child.poll() is None:
                child.send_signal(signal.SIGTERM)
        for child in children:
            try:
                child.wait(timeout=30)
            except subprocess.TimeoutExpired:
                child.kill()


@app.command("worker")
def worker_cmd(
    queues: str = typer.Option("training,evaluation", help="comma-separated queues to consume"),
    concurrency: int = typer.Option(None, help="worker processes (default ROMAMS_WORKER_CONCURRENCY)"),
    loglevel: str = typer.Option("info", help="Celery log level"),
    hostname: str = typer.Option(None, help="Celery node name (default celery@<host>)"),
) -> None:
    """Run a Celery worker of the service (broker ROMAMS_BROKER_URL, database ROMAMS_DATABASE_URL)."""
    from romams.settings import get_settings

    settings = get_settings()
    bad = set(q.strip() for q in queues.split(",")) - {"training", "evaluation"}
    if bad:
        raise typer.BadParameter(f"unknown queue(s) {sorted(bad)}; known: training, evaluation", param_hint="--queues")
    cmd = worker_command(queues, concurrency or settings.worker_concurrency, loglevel, hostname)
    os.execv(cmd[0], cmd)
