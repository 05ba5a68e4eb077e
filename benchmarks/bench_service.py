"""End-to-end service throughput over the HTTP API (embedded mode: SQLite + SQLite broker + real workers), as JSON.

Measures what an optimizer sees: latency of a synchronous single-structure flutter evaluation and of a
30-design batch (one DE generation), with a wing, a basis and UVLM ROMs trained through the API first.
Usage: python -m benchmarks.bench_service [--workers 2] [--machs 0.79,0.83,0.87,0.91,0.95] [--samples 10]
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from romams.persistence import FINAL, JobStatus

ROOT = Path(__file__).resolve().parents[1]


def _wait(client: Any, job_id: str, timeout_s: float = 900.0) -> dict[str, Any]:
    """Poll a job until it is final."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        job = client.get(f"/api/v1/jobs/{job_id}").json()
        if job["status"] in FINAL:
            return job
        time.sleep(0.1)
    raise TimeoutError(job_id)


def run(workers: int, machs: list[float], samples: int, modes: int, generations: int, pop: int) -> dict[str, Any]:
    """Set up a trained wing through the API, then time single and batch evaluations."""
    from fastapi.testclient import TestClient

    from api.app import create_app
    from romams.settings import Settings
    from romams_core.basis import random_designs
    from romams_core.wing import template

    with tempfile.TemporaryDirectory(prefix="romams-bench-") as tmp:
        env = {k: v for k, v in os.environ.items() if not k.startswith("ROMAMS_")}
        env.update(ROMAMS_DATA_DIR=tmp, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", PYTHONPATH=str(ROOT))
        log = open(Path(tmp) / "worker.log", "wb")  # noqa: SIM115
        proc = subprocess.Popen([sys.executable, "-m", "celery", "-A", "worker.celery_app", "worker", "-Q",
                                 "training,evaluation", "--concurrency", str(workers), "--loglevel", "warning",
                                 "--without-gossip", "--without-mingle"], cwd=ROOT, env=env, stdout=log,
                                stderr=subprocess.STDOUT, start_new_session=True)
        try:
            with TestClient(create_app(Settings(data_dir=Path(tmp), batch_sync_max=max(64, pop)))) as c:
                t0 = time.perf_counter()
                wid = c.post("/api/v1/wings", json={"template": "cropped-delta"}).json()["id"]
                job = c.post(f"/api/v1/wings/{wid}/basis", json={"samples": samples, "modes": modes}).json()
                basis = _wait(c, job["job_id"])
                t_basis = time.perf_counter() - t0
                t0 = time.perf_counter()
                ids = c.post(f"/api/v1/wings/{wid}/roms", json={"machs": machs}).json()["job_ids"]
                trained = [_wait(c, j) for j in ids]
                t_train = time.perf_counter() - t0
                if basis["status"] != JobStatus.SUCCEEDED or any(j["status"] != JobStatus.SUCCEEDED for j in trained):
                    raise RuntimeError(f"setup failed: {basis['error']} {[j['error'] for j in trained]}")
                wing = template("cropped-delta")
                c.post(f"/api/v1/wings/{wid}/flutter", json={"design": None, "store": False})  # warm workers
                singles = []
                for d in random_designs(wing, 20, seed=3).tolist():
                    t = time.perf_counter()
                    r = c.post(f"/api/v1/wings/{wid}/flutter", json={"design": d, "store": False})
                    singles.append(time.perf_counter() - t)
                    assert r.status_code == 200, r.text
                gens = []
                for g in range(generations):
                    designs = random_designs(wing, pop, seed=100 + g).tolist()
                    t = time.perf_counter()
                    r = c.post(f"/api/v1/wings/{wid}/flutter/batch", json={"designs": designs})
                    gens.append(time.perf_counter() - t)
                    assert r.status_code == 200 and len(r.json()["results"]) == pop, r.text
                t = time.perf_counter()
                c.post(f"/api/v1/wings/{wid}/flutter/batch", json={"designs": designs})
                cached = time.perf_counter() - t
        finally:
            proc.send_signal(signal.SIGTERM)
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
            log.close()
    per_design = statistics.median(gens) / pop
    return {
        "benchmark": "service", "workers": workers, "machs": machs, "samples": samples, "modes": modes,
        "n_basis": basis["result"]["n_basis"], "basis_job_s": round(t_basis, 2),
        "training_all_machs_s": round(t_train, 2),
        "single_eval_ms_median": round(1e3 * statistics.median(singles), 1),
        "single_eval_ms_p90": round(1e3 * sorted(singles)[int(0.9 * len(singles))], 1),
        "batch_size": pop, "batch_s_median": round(statistics.median(gens), 3),
        "batch_ms_per_design": round(1e3 * per_design, 1), "batch_cached_s": round(cached, 3),
        "projected_4530_designs_s": round(4530 * per_design, 1),
    }


def main() -> None:
    """CLI entry: print the JSON result."""
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--machs", default="0.79,0.83,0.87,0.91,0.95")
    p.add_argument("--samples", type=int, default=10)
    p.add_argument("--modes", type=int, default=4)
    p.add_argument("--generations", type=int, default=5)
    p.add_argument("--pop", type=int, default=30)
    a = p.parse_args()
    machs = [float(m) for m in a.machs.split(",")]
    print(json.dumps(run(a.workers, machs, a.samples, a.modes, a.generations, a.pop), indent=2))


if __name__ == "__main__":
    main()
