"""Fixtures of the service tests: real Celery worker subprocesses, fresh PostgreSQL databases, Redis."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
import uuid
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
from fast_settings import DLM_FAST

from benchmarks.live_service import free_port

ROOT = Path(__file__).resolve().parents[2]
CI = os.environ.get("CI", "").lower() == "true"
PG_ADMIN_URL = os.environ.get("ROMAMS_TEST_PG_URL", "postgresql://postgres@127.0.0.1:5432/test")
REDIS_URL = os.environ.get("ROMAMS_TEST_REDIS_URL", "redis://127.0.0.1:6379")


def service_env(data_dir: Path, **settings: object) -> dict[str, str]:
    """Environment for a worker subprocess: this test's data dir and settings, nothing inherited from ROMAMS_*."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("ROMAMS_")}
    env["ROMAMS_DATA_DIR"] = str(data_dir)
    env.update({f"ROMAMS_{k.upper()}": str(v) for k, v in settings.items()})
    env["PYTHONPATH"] = str(ROOT)
    return env


class WorkerProcess:
    """A real ``celery worker`` subprocess of the service (prefork pool)."""

    def __init__(self, env: dict[str, str], log: Path, concurrency: int = 2,
                 queues: str = "training,evaluation") -> None:
        self.log_path = log
        self._log = open(log, "ab")  # noqa: SIM115 - closed in stop()
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "celery", "-A", "worker.celery_app", "worker", "-Q", queues,
             "--concurrency", str(concurrency), "--loglevel", "info", "--without-gossip", "--without-mingle",
             "--hostname", f"test-{uuid.uuid4().hex[:6]}@%h"],
            cwd=ROOT, env=env, stdout=self._log, stderr=subprocess.STDOUT, start_new_session=True)

    def pool_pids(self) -> list[int]:
        """Pids of the prefork pool children."""
        path = Path(f"/proc/{self.proc.pid}/task/{self.proc.pid}/children")
        try:
            return [int(p) for p in path.read_text().split()]
        except OSError:
            return []

    def kill_all(self) -> None:
        """SIGKILL the worker and its pool at once (a machine dying)."""
        pids = self.pool_pids()
        os.kill(self.proc.pid, signal.SIGKILL)
        for p in pids:
            try:
                os.kill(p, signal.SIGKILL)
            except ProcessLookupError:
                pass
        self.proc.wait(timeout=10)

    def stop(self) -> None:
        """Warm shutdown (SIGTERM), then SIGKILL of this worker's process group if it lingers."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait(timeout=10)
        for p in self.pool_pids():
            try:
                os.kill(p, signal.SIGKILL)
            except ProcessLookupError:
                pass
        self._log.close()

    def log_tail(self, n: int = 4000) -> str:
        """End of the worker log (for assertion messages)."""
        return self.log_path.read_text(errors="replace")[-n:]


def wait_job(client, job_id: str, timeout_s: float = 240.0, until=("succeeded", "failed", "cancelled")) -> dict:
    """Poll GET /api/v1/jobs/{id} until its status is in ``until``."""
    deadline = time.monotonic() + timeout_s
    while True:
        job = client.get(f"/api/v1/jobs/{job_id}").json()
        if job["status"] in until:
            return job
        if time.monotonic() > deadline:
            raise AssertionError(f"job {job_id} still {job['status']} after {timeout_s} s: {job}")
        time.sleep(0.1)


def _unavailable(what: str, exc: Exception) -> None:
    """Skip locally, fail under CI=true."""
    msg = f"{what} not reachable: {exc}"
    if CI:
        pytest.fail(msg + " (CI=true: services tests must not skip)")
    pytest.skip(msg)


@pytest.fixture()
def pg_url() -> Iterator[str]:
    """URL of a fresh, empty PostgreSQL database (dropped afterwards)."""
    try:
        import psycopg

        admin = psycopg.connect(PG_ADMIN_URL, autocommit=True, connect_timeout=5)
    except Exception as exc:  # noqa: BLE001
        _unavailable("PostgreSQL at 127.0.0.1:5432", exc)
    name = f"romams_test_{uuid.uuid4().hex[:10]}"
    admin.execute(f'CREATE DATABASE "{name}"')
    base = PG_ADMIN_URL.rsplit("/", 1)[0].replace("postgresql://", "postgresql+psycopg://", 1)
    try:
        yield f"{base}/{name}"
    finally:
        from romams.persistence import dispose_engines

        dispose_engines()
        admin.execute(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')
        admin.close()


@pytest.fixture()
def redis_url() -> Iterator[str]:
    """A Redis broker URL on a database number of its own, flushed afterwards."""
    try:
        import redis

        r0 = redis.Redis.from_url(REDIS_URL, socket_connect_timeout=5)
        r0.ping()
    except Exception as exc:  # noqa: BLE001
        _unavailable("Redis at 127.0.0.1:6379", exc)
    # databases 8-15, split between pytest-xdist workers (gw0: 8-11, gw1: 12-15) so that two tests running at
    # the same time never share (and flush) one database
    worker = os.environ.get("PYTEST_XDIST_WORKER", "gw0")
    slot = int(worker[2:]) % 2 if worker[2:].isdigit() else 0
    db = 8 + 4 * slot + uuid.uuid4().int % 4
    r = redis.Redis.from_url(f"{REDIS_URL}/{db}")
    r.flushdb()
    try:
        yield f"{REDIS_URL}/{db}"
    finally:
        r.flushdb()


class SentTasks:
    """Stand-in for the Celery app of an API under test: records the tasks it sends (no broker, no worker)."""

    def __init__(self) -> None:
        self.sent: list[tuple[str, list, str | None]] = []

    def send_task(self, name: str, args: list | None = None, task_id: str | None = None, **_: object) -> None:
        self.sent.append((name, list(args or []), task_id))


#: the shared embedded service (sqlite_service): Mach numbers of its ROMs and its fast settings
SQLITE_MACHS = [0.79, 0.87]
SQLITE_FAST = {"heartbeat_s": 0.5, "job_stale_s": 8.0, "batch_sync_max": 4, "sync_timeout_s": 120}


@pytest.fixture(scope="package")
def sqlite_service(tmp_path_factory):
    """The embedded configuration with a real worker subprocess (SQLite database and broker): a cropped-delta wing
    "cd-test", a basis (6 LHS samples x 3 modes) and dlm ROMs at SQLITE_MACHS (DLM_FAST). Shared by
    test_api_sqlite.py and test_runs.py (trained once per test process); a test may replace ``worker`` (it is
    stopped at the end)."""
    from types import SimpleNamespace

    from fastapi.testclient import TestClient

    from api.app import create_app
    from romams.settings import Settings

    data = tmp_path_factory.mktemp("romams-sqlite")
    settings = Settings(data_dir=data, **SQLITE_FAST)
    env = service_env(data, **SQLITE_FAST)
    worker = WorkerProcess(env, data / "worker.log")
    app = create_app(settings)
    try:
        with TestClient(app) as client:
            ns = SimpleNamespace(client=client, settings=settings, env=env, data=data, worker=worker, app=app)
            r = client.post("/api/v1/wings", json={"template": "cropped-delta", "name": "cd-test"})
            assert r.status_code == 201, r.text
            ns.wing_id = r.json()["id"]
            r = client.post(f"/api/v1/wings/{ns.wing_id}/basis", json={"samples": 6, "modes": 3, "seed": 1})
            assert r.status_code == 202, r.text
            ns.basis_job = wait_job(client, r.json()["job_id"])
            assert ns.basis_job["status"] == "succeeded", (ns.basis_job, worker.log_tail())
            r = client.post(f"/api/v1/wings/{ns.wing_id}/roms", json={"machs": SQLITE_MACHS, "options": DLM_FAST})
            assert r.status_code == 202, r.text
            ns.train_request = r.json()
            ns.train_jobs = [wait_job(client, j) for j in r.json()["job_ids"]]
            assert all(j["status"] == "succeeded" for j in ns.train_jobs), (ns.train_jobs, worker.log_tail())
            yield ns
    finally:
        ns_worker = worker if "ns" not in locals() else ns.worker
        ns_worker.stop()


#: parameters of a fixture that runs on SQLite and (services) on PostgreSQL; see backend_settings
BACKENDS = ["sqlite", pytest.param("postgresql", marks=pytest.mark.services)]


def backend_settings(request, tmp_path: Path, **kw: object):
    """Settings on SQLite, or (``request.param == "postgresql"``) on a fresh PostgreSQL database at Alembic head."""
    from romams.persistence import open_store
    from romams.settings import Settings

    if request.param == "postgresql":
        settings = Settings(data_dir=tmp_path / "data", database_url=request.getfixturevalue("pg_url"), **kw)
        open_store(settings, migrate=True)
        return settings
    return Settings(data_dir=tmp_path / "data", **kw)


@pytest.fixture()
def server(tmp_path):
    """`romams serve` (uvicorn + embedded child worker, SQLite under tmp_path) on a free port: (base URL, tmp_path);
    stopped with SIGTERM at the end, and its worker must go with it."""
    port = free_port()
    env = service_env(tmp_path / "data", port=port, heartbeat_s=0.5)
    log = open(tmp_path / "serve.log", "wb")  # noqa: SIM115
    cmd = [sys.executable, "-c", "from romams.cli import main; main()", "serve", "--loglevel", "info"]
    proc = subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    base = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 60
    while True:
        try:
            if httpx.get(f"{base}/api/v1/health", timeout=2).status_code == 200:
                break
        except httpx.HTTPError:
            pass
        if proc.poll() is not None or time.monotonic() > deadline:
            raise AssertionError((tmp_path / "serve.log").read_text()[-3000:])
        time.sleep(0.3)
    children = Path(f"/proc/{proc.pid}/task/{proc.pid}/children")
    worker_pids = [int(p) for p in children.read_text().split()]
    assert len(worker_pids) == 2, "romams serve starts a training and an evaluation worker"
    try:
        yield base, tmp_path
    finally:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=40)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
        log.close()
        deadline = time.monotonic() + 60  # the embedded worker goes with the server (warm shutdown)
        while any(Path(f"/proc/{p}").exists() and "zombie" not in _state(p) for p in worker_pids):
            if time.monotonic() > deadline:
                os.killpg(proc.pid, signal.SIGKILL)
                raise AssertionError("the embedded worker outlived `romams serve`")
            time.sleep(0.2)


def _state(pid: int) -> str:
    """Process state line from /proc (empty if gone)."""
    try:
        return next(line for line in Path(f"/proc/{pid}/status").read_text().splitlines() if line.startswith("State"))
    except (OSError, StopIteration):
        return "zombie"
