"""`romams worker` and `romams serve`: argument checks and the exact Celery command they run."""

from __future__ import annotations

import subprocess
import sys

from romams.cli.service import worker_command

from .conftest import ROOT, service_env


def _romams(args: list[str], env: dict[str, str]) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", "from romams.cli import main; main()", *args], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=120)


def test_worker_command_targets_the_service_app_and_queues():
    cmd = worker_command("training,evaluation", 3, "info", "w1@%h")
    assert cmd[:5] == [sys.executable, "-m", "celery", "-A", "worker.celery_app"]
    assert cmd[cmd.index("-Q") + 1] == "training,evaluation" and cmd[cmd.index("--concurrency") + 1] == "3"
    assert cmd[cmd.index("--hostname") + 1] == "w1@%h"


def test_worker_rejects_unknown_queues(tmp_path):
    r = _romams(["worker", "--queues", "training,bogus"], service_env(tmp_path))
    assert r.returncode == 2 and "bogus" in r.stderr


def test_worker_and_serve_help(tmp_path):
    for cmd in ("worker", "serve"):
        r = _romams([cmd, "--help"], service_env(tmp_path))
        assert r.returncode == 0 and "--concurrency" in r.stdout


def test_declare_queues_creates_the_embedded_broker_queues_once(tmp_path):
    """`romams serve` declares the queues before its workers start (no create-table race among 3 processes)."""
    import sqlite3

    from romams.services.queue import declare_queues
    from romams.settings import Settings

    settings = Settings(data_dir=tmp_path)
    declare_queues(settings)
    declare_queues(settings)  # idempotent: a restart finds them there
    with sqlite3.connect(tmp_path / "broker.db") as db:
        names = sorted(r[0] for r in db.execute("select name from kombu_queue"))
    assert names == ["evaluation", "training"]
