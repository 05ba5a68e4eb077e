"""Distributed configuration: PostgreSQL database, Redis broker, two real worker processes (marker ``services``).

A basis job and a training job run to completion through the API; a worker process killed with SIGKILL in the
middle of a training job does not lose it.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys

import pytest
from fastapi.testclient import TestClient

from api.app import create_app
from romams.settings import Settings

from .conftest import ROOT, WorkerProcess, service_env, wait_job

pytestmark = pytest.mark.services


def _migrated(tmp_path, env_settings: dict) -> tuple[dict[str, str], Settings]:
    """Worker environment and API settings of a deployment whose database was migrated to head by Alembic."""
    env = service_env(tmp_path, **env_settings)
    up = subprocess.run([sys.executable, "-m", "alembic", "upgrade", "head"], cwd=ROOT, env=env, capture_output=True,
                        text=True, timeout=120)
    assert up.returncode == 0, up.stderr
    return env, Settings(data_dir=tmp_path, **env_settings)


def test_basis_training_and_worker_crash_on_postgres_and_redis(tmp_path, pg_url, redis_url):
    env_settings = {"database_url": pg_url, "broker_url": redis_url, "heartbeat_s": 0.5, "job_stale_s": 8.0,
                    "broker_visibility_timeout_s": 30}
    env, settings = _migrated(tmp_path, env_settings)
    workers = [WorkerProcess(env, tmp_path / f"w{i}.log", concurrency=1) for i in range(2)]  # "two machines"
    try:
        with TestClient(create_app(settings)) as c:
            assert c.get("/api/v1/health").json()["database"] == "postgresql"
            wid = c.post("/api/v1/wings", json={"template": "cropped-delta"}).json()["id"]
            r = c.post(f"/api/v1/wings/{wid}/basis", json={"samples": 4, "modes": 3, "seed": 2})
            basis = wait_job(c, r.json()["job_id"])
            assert basis["status"] == "succeeded", (basis, workers[0].log_tail(), workers[1].log_tail())
            chunk_workers = {k["worker"] for k in c.get("/api/v1/jobs", params={"include_children": True,
                                                                              "kind": "basis-chunk"}).json()}
            assert len(chunk_workers) >= 1
            b = c.get(f"/api/v1/wings/{wid}/bases").json()[0]
            assert b["summary"]["min_mac"] >= 0.98

            r = c.post(f"/api/v1/wings/{wid}/roms", json={"mach": 0.8, "solver": "uvlm", "options": {"n_steps": 12000}})
            assert r.status_code == 202
            jid = r.json()["job_id"]
            job = wait_job(c, jid, 120, until=("running", "succeeded", "failed"))
            assert job["status"] == "running"
            pid = int(job["worker"].rsplit(":", 1)[1])
            os.kill(pid, signal.SIGKILL)  # the pool process running the training dies
            job = wait_job(c, jid, 300)
            assert job["status"] == "succeeded", (job, workers[0].log_tail(), workers[1].log_tail())
            assert job["deliveries"] >= 2
            roms = c.get(f"/api/v1/wings/{wid}/roms").json()
            assert [x["mach"] for x in roms] == [0.8] and max(roms[0]["summary"]["validation_nrmse"]) < 0.02
            again = c.post(f"/api/v1/wings/{wid}/roms",
                           json={"mach": 0.8, "solver": "uvlm", "options": {"n_steps": 12000}})
            assert again.status_code == 200 and again.json()["rom_id"] == roms[0]["id"]
            out = c.post(f"/api/v1/wings/{wid}/flutter", json={"design": [0.3, 0.4, 0.7, 0.05, 1.0, 1.0, 0.8]})
            assert out.status_code == 200, out.text
            assert out.json()["results"][0]["mach"] == 0.8 and out.json()["mass_kg"] > 0
    finally:
        for w in workers:
            w.stop()


def test_queued_jobs_survive_a_broker_that_lost_their_messages(tmp_path, pg_url, redis_url):
    """Redis restarted without persistence: the queued job's message is gone; the sweeper re-sends it."""
    import redis

    env_settings = {"database_url": pg_url, "broker_url": redis_url, "heartbeat_s": 0.5, "job_stale_s": 8.0,
                    "job_queued_resend_s": 3.0}
    env, settings = _migrated(tmp_path, env_settings)
    with TestClient(create_app(settings)) as c:
        wid = c.post("/api/v1/wings", json={"template": "cropped-delta"}).json()["id"]
        r = c.post(f"/api/v1/wings/{wid}/basis", json={"samples": 4, "modes": 3, "seed": 2})
        jid = r.json()["job_id"]
        redis.Redis.from_url(redis_url).flushdb()  # no worker yet: the message is lost with the broker's memory
        assert c.get(f"/api/v1/jobs/{jid}").json()["status"] == "queued"
        worker = WorkerProcess(env, tmp_path / "w.log", concurrency=1)
        try:
            job = wait_job(c, jid, 240)
            assert job["status"] == "succeeded", (job, worker.log_tail())
            assert c.get(f"/api/v1/wings/{wid}/bases").json()[0]["summary"]["n_basis"] >= 1
        finally:
            worker.stop()
