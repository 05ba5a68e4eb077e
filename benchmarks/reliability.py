"""Reliability figures of the service, printed as ONE JSON object.

    python -m benchmarks.reliability --json [--quick]

Built from the service tests' own machinery (tests/service), run here with counters instead of assertions:
- faults (distributed; test_faults.open_deployment: a Redis without persistence and a PostgreSQL cluster that this
  run starts on ports of its own, a real worker process, the API with its sweeper): a training runs and basis jobs
  wait in the queue when Redis is killed and restarted empty; then, under the test's request loop (test_faults.Load),
  PostgreSQL is stopped and started (``sync_timeout_s`` 5 s, as in the test: an evaluation that the outage holds up
  answers 202 after 5 s instead of keeping the loop waiting through the outage). ``jobs_stuck``: jobs (children
  included) still queued or running at the end of the settling time; ``jobs_lost``: the others that did not end
  succeeded. ``broker_recovery_s``: the first
  synchronous evaluation after the Redis restart; ``outage_requests``/``outage_503``/``outage_other_errors``: the
  loop's requests, its 503s (with Retry-After) and anything else of 5xx or a dropped connection.
- fuzz: test_schemathesis.fuzz over every operation of the OpenAPI document, positive and negative cases, on the
  test's seeded store: ``fuzz_cases`` responses, ``fuzz_5xx`` of them 5xx (``fuzz_failures``: any failed check).
- bad inputs: the hand-written bad-input tests (test_bad_input.py, test_reliability.py and test_security.py but
  their database/broker outage cases, which answer 503 on purpose), run by pytest with every TestClient request
  counted: ``bad_inputs_tried`` requests, ``bad_inputs_5xx`` of them 5xx (``bad_input_tests_failed``).
- embedded (``romams serve``, benchmarks.live_service, with an API key): ``upload_bomb_peak_rss_mb``, the API
  process's peak RSS growth while it rejects a 9 MB NPZ upload that inflates to 2 GiB (sampled every 2 ms
  and from VmHWM); then ``load_clients`` clients send synchronous evaluations (random designs, one Mach) for
  ``load_seconds``: ``load_errors`` (anything but 200), ``p50_s``/``p99_s`` latency, ``single_client_p50_s``
  (one client for half as long, after 5 warm-up evaluations that load the models), ``p99_over_single``;
  ``api_rss_growth_pct``/``worker_rss_growth_pct``: RSS growth of the API process and
  of the worker processes (all together) from after the one-client phase to after the load
  (``api_rss_mb``/``worker_rss_mb``: MiB after the one-client phase, after the closed loop, after the paced phase).
  The load phase is a closed loop (every client sends its next request as soon as it has an answer), so its
  latency is the queue in front of the evaluation workers: 50 clients / the throughput. A second, paced phase
  of the same clients and length adds exponential think times so that the offered load is ``PACED_LOAD`` (half)
  of the closed loop's throughput (``load_throughput_per_s``): ``paced_p50_s``/``paced_p99_s``/
  ``paced_p99_over_single`` show the latency of 50 concurrent clients when the workers are not saturated.
- distributed: the same load phases on a PostgreSQL and a Redis that this run starts on ports of its own (the API
  and its child workers, ``romams serve``, use them): the same keys with ``distributed_`` in front
  (``distributed_api_rss_growth_pct``, ``distributed_worker_rss_growth_pct``, ``distributed_p99_s``, ...).
``--quick``: short phases (8 clients x 10 s of load, 3 cases per operation and mode, a 5 s PostgreSQL outage);
without: 50 clients x 60 s, 20 cases, 15 s. Progress goes to stderr.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import sys
import tempfile
import threading
import time
import zipfile
from collections import Counter
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
KEY = "reliability-benchmark-key-0123456789"
DESIGN = [0.3, 0.4, 0.7, 0.05, 1.0, 1.0, 0.8]
RFA_FAST = {"k_values": [0.0, 0.1, 0.3, 0.6], "n_lags": 1}
WARM_UP = 5  # evaluations before any latency is measured
PACED_LOAD = 0.5  # offered load of the paced phase, as a fraction of the closed-loop phase's throughput
BAD_INPUT_TESTS = ("test_bad_input.py", "test_reliability.py", "test_security.py")


@dataclass(frozen=True)
class Plan:
    """Sizes of the phases."""

    fuzz_examples: int
    load_clients: int
    load_seconds: float
    pg_outage_s: float
    settle_s: float


QUICK = Plan(fuzz_examples=3, load_clients=8, load_seconds=10.0, pg_outage_s=5.0, settle_s=300.0)
FULL = Plan(fuzz_examples=20, load_clients=50, load_seconds=60.0, pg_outage_s=15.0, settle_s=600.0)


def service_tests(module: str) -> Any:
    """A module of tests/service, imported as pytest names it (``service.<module>``, tests/ on the path: an
    installed distribution may own the name ``tests``)."""
    import importlib

    if str(ROOT / "tests") not in sys.path:
        sys.path.insert(0, str(ROOT / "tests"))
    return importlib.import_module(f"service.{module}")


def log(msg: str) -> None:
    """Progress line on stderr."""
    print(f"[reliability] {msg}", file=sys.stderr, flush=True)


def _skipped(phase: str, exc: BaseException) -> dict[str, Any]:
    """The note of a phase that could not run (e.g. no PostgreSQL binaries)."""
    log(f"{phase} skipped: {exc}")
    return {f"{phase}_skipped": str(exc)[:300]}


def faults(plan: Plan, tmp: Path) -> dict[str, Any]:
    """Redis restart without persistence, then a PostgreSQL outage under load; jobs lost and stuck."""
    tf, wait_job = service_tests("test_faults"), service_tests("conftest").wait_job
    tmp.mkdir(parents=True, exist_ok=True)
    postgres = service_tests("servers").PostgresServer().start()
    try:
        with tf.open_deployment(tmp, postgres, worker_concurrency=2, sync_timeout_s=5.0) as d:
            tf.seed_basis(d.store, d.wing_id)
            first = wait_job(d.client, tf.training_running(d, 0.5), 300)
            log(f"faults: first training {first['status']}")
            tf.training_running(d, 0.6, tf.RFA_LONG)  # still running when Redis goes down
            for seed in (1, 2, 3):
                tf.submit_basis(d, seed)
            d.redis.stop()
            time.sleep(1.0)
            d.redis.start()
            t0 = time.monotonic()
            r = d.client.post(f"/api/v1/wings/{d.wing_id}/flutter", json={"design": DESIGN, "machs": [0.5],
                                                                            "store": False})
            recovery = time.monotonic() - t0
            log(f"faults: Redis restarted, first evaluation {r.status_code} in {recovery:.2f} s")
            with tf.Load(d) as load:
                time.sleep(1.0)
                d.postgres.stop()
                time.sleep(plan.pg_outage_s)
                d.postgres.start()
                time.sleep(3.0)
            log(f"faults: PostgreSQL restarted; settling (at most {plan.settle_s:.0f} s)")
            jobs, active = tf.settle(d, plan.settle_s)
    finally:
        postgres.remove()
    active_ids = {j["id"] for j in active}
    return {"jobs_lost": sum(j["status"] != "succeeded" for j in jobs if j["id"] not in active_ids),
            "jobs_stuck": len(active), "jobs_total": len(jobs),
            "broker_recovery_s": round(recovery, 3) if r.status_code == 200 else None,
            "outage_requests": sum(load.seen.values()),
            "outage_503": sum(n for (_, _, status), n in load.seen.items() if status == 503),
            "outage_other_errors": len(load.bad)}


def fuzz(plan: Plan, tmp: Path) -> dict[str, Any]:
    """Schemathesis over the whole API (the test's seeded store), positive and negative cases."""
    import schemathesis
    from schemathesis.generation import GenerationMode

    ts = service_tests("test_schemathesis")
    seen: Counter = Counter()
    failures: list[str] = []
    with ts.seeded(tmp) as (app, _, real):
        schema = schemathesis.openapi.from_asgi("/openapi.json", app)
        for mode in (GenerationMode.POSITIVE, GenerationMode.NEGATIVE):
            failures += ts.fuzz(schema, real, mode, plan.fuzz_examples, seen)
    for f in failures[:5]:
        log(f"fuzz failure: {f.splitlines()[0]}")
    return {"fuzz_cases": sum(seen.values()), "fuzz_5xx": sum(n for (s, _), n in seen.items() if s >= 500),
            "fuzz_failures": len(failures)}


class _Outcomes:
    """pytest plugin: counts failed tests."""

    def __init__(self) -> None:
        self.failed = 0

    def pytest_runtest_logreport(self, report: Any) -> None:
        if report.failed:
            self.failed += 1


def bad_inputs() -> dict[str, Any]:
    """The bad-input tests run by pytest, every TestClient request's status counted."""
    import pytest
    from starlette.testclient import TestClient

    statuses: Counter = Counter()
    original: Callable[..., Any] = TestClient.request

    def counted(self: Any, *args: Any, **kwargs: Any) -> Any:
        response = original(self, *args, **kwargs)
        statuses[response.status_code] += 1
        return response

    outcomes = _Outcomes()
    TestClient.request = counted  # type: ignore[method-assign]
    try:
        files = [str(ROOT / "tests" / "service" / f) for f in BAD_INPUT_TESTS]
        code = pytest.main([*files, "-q", "-p", "no:cacheprovider", "-m", "not services", "-k",
                            "not unreachable and not outage"], plugins=[outcomes])
    finally:
        TestClient.request = original  # type: ignore[method-assign]
    return {"bad_inputs_tried": sum(statuses.values()), "bad_inputs_5xx": sum(n for s, n in statuses.items()
                                                                              if s >= 500),
            "bad_input_tests_failed": outcomes.failed, "bad_input_pytest_exit": int(code)}


def bomb_npz(inflated: int = 2 << 30) -> bytes:
    """A modes NPZ whose ``shapes`` member inflates to ``inflated`` bytes of zeros (test_reliability's bomb)."""
    tr = service_tests("test_reliability")
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED, compresslevel=1) as zf:  # fast to make, ~1000:1
        zf.writestr("nodes.npy", tr._npy(tr._modes_arrays()["nodes"]))
        zf.writestr("frequencies_hz.npy", tr._npy(np.array([10.0])))
        with zf.open("shapes.npy", "w", force_zip64=True) as f:
            f.write(tr._npy_header((inflated // 8,)))
            zero = bytes(1 << 20)
            for _ in range(inflated >> 20):
                f.write(zero)
    return buf.getvalue()


def _status_kb(pid: int, field: str) -> int:
    """A ``Vm*`` line of /proc/<pid>/status, kB (0 when the process is gone)."""
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith(field + ":"):
                return int(line.split()[1])
    except OSError:
        pass
    return 0


def rss_mb(pids: list[int]) -> float:
    """Resident memory of these processes together, MiB."""
    return sum(_status_kb(p, "VmRSS") for p in pids) / 1024


def upload_bomb(client: Any, pid: int) -> dict[str, Any]:
    """Peak RSS growth (MiB) of the API process ``pid`` while it answers the 2 GiB bomb upload."""
    data = bomb_npz()
    base, hwm0 = _status_kb(pid, "VmRSS"), _status_kb(pid, "VmHWM")
    peak = [base]
    stop = threading.Event()

    def sample() -> None:
        while not stop.is_set():
            peak.append(_status_kb(pid, "VmRSS"))
            time.sleep(0.002)

    t = threading.Thread(target=sample, daemon=True)
    t.start()
    r = client.post("/api/v1/modes", files={"file": ("bomb.npz", data)})
    stop.set()
    t.join()
    hwm1 = _status_kb(pid, "VmHWM")
    grown = max(max(peak) - base, (hwm1 - base) if hwm1 > hwm0 else 0) / 1024
    log(f"bomb: {len(data) / 1e6:.1f} MB upload -> {r.status_code}, peak RSS growth {grown:.1f} MiB")
    return {"upload_bomb_peak_rss_mb": round(grown, 1), "upload_bomb_status": r.status_code,
            "upload_bomb_bytes": len(data)}


def load(url: str, wid: int, clients: int, seconds: float, designs: list[list[float]],
         think_s: float = 0.0) -> dict[str, Any]:
    """``clients`` threads posting synchronous evaluations for ``seconds``: latencies (s) and errors. With
    ``think_s`` each client pauses an exponentially distributed time of that mean (s) after every answer."""
    import httpx

    latencies: list[float] = []
    errors: Counter = Counter()
    end = time.monotonic() + seconds

    def one_client(i: int) -> None:
        rng = np.random.default_rng(i)
        with httpx.Client(base_url=url, headers={"Authorization": f"Bearer {KEY}"}, timeout=120) as c:
            k = i
            while time.monotonic() < end:
                if think_s > 0:
                    time.sleep(min(rng.exponential(think_s), max(0.0, end - time.monotonic())))
                    if time.monotonic() >= end:
                        break
                t = time.perf_counter()
                try:
                    r = c.post(f"/api/v1/wings/{wid}/flutter",
                               json={"design": designs[k % len(designs)], "machs": [0.5], "store": False})
                    status: int | str = r.status_code
                except httpx.HTTPError as exc:
                    status = type(exc).__name__
                k += clients
                if status == 200:
                    latencies.append(time.perf_counter() - t)
                else:
                    errors[status] += 1

    with ThreadPoolExecutor(clients) as pool:
        list(pool.map(one_client, range(clients)))
    lat = np.array(latencies or [np.nan])
    return {"requests": len(latencies) + sum(errors.values()), "errors": sum(errors.values()),
            "error_kinds": {str(k): v for k, v in errors.items()}, "p50_s": float(np.percentile(lat, 50)),
            "p99_s": float(np.percentile(lat, 99))}


def load_phases(svc: Any, c: Any, store: Any, plan: Plan, label: str) -> dict[str, Any]:
    """On a live service ``svc`` (client ``c``, its ``store``): a ROM, then one client, the closed loop and the
    paced phase of ``plan``, with the RSS of the API and the worker processes after each (the JSON keys)."""
    from romams_core.basis import random_designs
    from romams_core.wing import template

    tf, wait_job = service_tests("test_faults"), service_tests("conftest").wait_job
    wid = c.post("/api/v1/wings", json={"template": "cropped-delta"}).json()["id"]
    tf.seed_basis(store, wid)
    job = c.post(f"/api/v1/wings/{wid}/roms", json={"mach": 0.5, "options": RFA_FAST}).json()
    log(f"{label}: training {wait_job(c, job['job_id'], 600)['status']}")
    designs = random_designs(template("cropped-delta"), 5000, seed=7).tolist()
    # disjoint designs per phase: a design seen before is answered from a worker's result cache
    single, closed, paced_designs = designs[:1000], designs[1000:3000], designs[3000:-WARM_UP]
    for d in designs[-WARM_UP:]:  # the first requests load the basis and ROM into the workers' caches
        c.post(f"/api/v1/wings/{wid}/flutter", json={"design": d, "machs": [0.5], "store": False})
    warm = load(svc.url, wid, 1, max(5.0, plan.load_seconds / 2), single)
    api0, workers0 = rss_mb([svc.proc.pid]), rss_mb(svc.worker_pids())
    log(f"{label}: one client p50 {warm['p50_s']:.3f} s; load {plan.load_clients} clients x "
        f"{plan.load_seconds:.0f} s (API {api0:.0f} MiB, workers {workers0:.0f} MiB)")
    res = load(svc.url, wid, plan.load_clients, plan.load_seconds, closed)
    api_mid, workers_mid = rss_mb([svc.proc.pid]), rss_mb(svc.worker_pids())
    capacity = max(res["requests"], 1) / plan.load_seconds  # > 0: the paced phase divides by it
    think = plan.load_clients / (PACED_LOAD * capacity)  # offered rate = PACED_LOAD x the closed loop's
    log(f"{label}: closed loop p99 {res['p99_s']:.3f} s, {capacity:.1f}/s; paced phase, think {think:.2f} s")
    paced = load(svc.url, wid, plan.load_clients, plan.load_seconds, paced_designs, think_s=think)
    api1, workers1 = rss_mb([svc.proc.pid]), rss_mb(svc.worker_pids())
    log(f"{label}: paced p99 {paced['p99_s']:.3f} s; API {api1:.0f} MiB, workers {workers1:.0f} MiB")
    return {"load_clients": plan.load_clients, "load_seconds": plan.load_seconds,
            "load_requests": res["requests"], "load_errors": res["errors"], "load_error_kinds": res["error_kinds"],
            "p50_s": round(res["p50_s"], 4), "p99_s": round(res["p99_s"], 4),
            "single_client_p50_s": round(warm["p50_s"], 4),
            "p99_over_single": round(res["p99_s"] / warm["p50_s"], 2),
            "load_throughput_per_s": round(capacity, 2),
            "paced_offered_fraction": PACED_LOAD, "paced_think_s": round(think, 3),
            "paced_requests": paced["requests"], "paced_errors": paced["errors"],
            "paced_p50_s": round(paced["p50_s"], 4), "paced_p99_s": round(paced["p99_s"], 4),
            "paced_p99_over_single": round(paced["p99_s"] / warm["p50_s"], 2),
            "api_rss_mb": [round(api0, 1), round(api_mid, 1), round(api1, 1)],
            "worker_rss_mb": [round(workers0, 1), round(workers_mid, 1), round(workers1, 1)],
            "api_rss_growth_pct": round(100 * (api1 - api0) / api0, 1),
            "worker_rss_growth_pct": round(100 * (workers1 - workers0) / workers0, 1)}


def embedded(plan: Plan, tmp: Path) -> dict[str, Any]:
    """``romams serve`` with a key (SQLite, server-less broker): the upload bomb, then the load phases."""
    import httpx

    from benchmarks.live_service import LiveService
    from romams.persistence import open_store
    from romams.settings import Settings

    with LiveService(tmp, concurrency=2, api_keys=KEY) as svc, httpx.Client(
            base_url=svc.url, headers={"Authorization": f"Bearer {KEY}"}, timeout=300) as c:
        out = upload_bomb(c, svc.proc.pid)
        out.update(load_phases(svc, c, open_store(Settings(data_dir=tmp)), plan, "embedded"))
    return out


def distributed(plan: Plan, tmp: Path) -> dict[str, Any]:
    """The same load phases on PostgreSQL and Redis (servers this run starts on ports of its own; the API and
    its workers are the processes of ``romams serve`` on them): the keys of :func:`load_phases` with
    ``distributed_`` in front."""
    import httpx

    from benchmarks.live_service import LiveService
    from romams.persistence import dispose_engines, open_store
    from romams.settings import Settings

    servers = service_tests("servers")
    tmp.mkdir(parents=True, exist_ok=True)
    postgres = servers.PostgresServer().start()
    redis = servers.RedisServer(tmp).start()
    try:
        urls = {"database_url": postgres.create_database(), "broker_url": redis.url}
        store = open_store(Settings(data_dir=tmp / "data", **urls), migrate=True)
        with LiveService(tmp / "data", concurrency=2, api_keys=KEY, **urls) as svc, httpx.Client(
                base_url=svc.url, headers={"Authorization": f"Bearer {KEY}"}, timeout=300) as c:
            out = load_phases(svc, c, store, plan, "distributed")
    finally:
        dispose_engines()
        redis.stop()
        postgres.remove()
    return {f"distributed_{k}": v for k, v in out.items()}


def main() -> None:
    """Run the phases and print the JSON object."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true", help="print only the JSON object on stdout (one line)")
    ap.add_argument("--quick", action="store_true", help="short phases")
    args = ap.parse_args()
    plan = QUICK if args.quick else FULL
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    t0 = time.monotonic()
    out: dict[str, Any] = {"quick": args.quick}
    # stdout carries the JSON object only: pytest's and hypothesis' output goes to stderr
    with tempfile.TemporaryDirectory(prefix="romams-reliability-") as tmp, contextlib.redirect_stdout(sys.stderr):
        out.update(bad_inputs())
        log(f"bad inputs: {out['bad_inputs_tried']} requests, {out['bad_inputs_5xx']} 5xx")
        out.update(fuzz(plan, Path(tmp) / "fuzz"))
        log(f"fuzz: {out['fuzz_cases']} cases, {out['fuzz_5xx']} 5xx")
        try:
            out.update(faults(plan, Path(tmp) / "faults"))
        except BaseException as exc:  # noqa: BLE001 - pytest's Skipped (no server binaries) is a BaseException
            if isinstance(exc, KeyboardInterrupt):
                raise
            out.update({"jobs_lost": None, "jobs_stuck": None, **_skipped("faults", exc)})
        out.update(embedded(plan, Path(tmp) / "embedded"))
        try:
            out.update(distributed(plan, Path(tmp) / "distributed"))
        except BaseException as exc:  # noqa: BLE001 - as for the faults phase
            if isinstance(exc, KeyboardInterrupt):
                raise
            out.update(_skipped("distributed", exc))
    out["wall_s"] = round(time.monotonic() - t0, 1)
    print(json.dumps(out) if args.json else json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
