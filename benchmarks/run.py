"""The project's speed benchmarks in one run, printed as ONE JSON object.

    python -m benchmarks.run [--quick] [--json] [--all]

- eig_calibration_ms: median time of numpy.linalg.eigvals on a fixed set of 40 x 40 real matrices, measured
  in the same run; structure_eval_over_eig = structure_eval_ms / eig_calibration_ms is machine-independent.
- structure_eval_ms: one structure = modal analysis + flutter at 5 Mach numbers (projection on the
  basis, ROM to modal coordinates, flutter search, envelope), in process, one core, median over
  random designs; the basis and the ROMs of ``--solver`` (default dlm: rational-function ROMs; uvlm: ARX)
  are built in process first (their timings are reported).
- batched_structure_ms: one structure inside a batch of 30 (a DE generation): modal analysis per design and the
  flutter searches of the 30 structures at each Mach run together (``evaluate_structures``), CPU time of one core
  per batch / 30, median over batches (2 with --quick, 5 without); batched_over_eig = batched_structure_ms /
  eig_calibration_ms. ``batched_structure.eigen_solves_per_mach``: full eigen-solves per search.
- worker_rss_growth_pct: RSS growth (%) of this process evaluating designs in chunks through the evaluation use
  case a worker's flutter_chunk runs (``evaluate_designs_summary``): 10 000 designs, 640 with --quick; RSS after
  the first chunk against after the last.
- de_4530_http_s (not with --quick): the DE of optimization_wall_s alone (150 generations x 30 = 4 530
  structures over HTTP, 2 workers), setup excluded.
- rom_pms_over_rom_ams: cost of one structure by ROM-PMS (ROMs trained on the structure's own modes at the
  5 Machs, then the same flutter analysis) over its ROM-AMS cost, same run; with the flutter-speed
  differences between the two. With the dlm, the factorized AICs of the basis training are reused, so this is
  the cost of the solves and fits, not of a new aerodynamic run.
- batch_throughput_per_s: designs per second through POST /flutter/batch of a live embedded service
  (``romams serve``, SQLite, child worker) that this benchmark starts, with 1 and 2 worker processes;
  worker_peak_rss_mb: peak resident memory (VmHWM) of the worker processes over a 1 000-design batch.
- http_over_inprocess: median wall time of one synchronous evaluation through POST /flutter of a live
  service (one evaluation worker) over the same work in process (the evaluation use case on the same
  stored models and designs). Measured on the distributed deployment (PostgreSQL + Redis at 127.0.0.1)
  when those servers answer (``http_over_inprocess_mode``), else on the embedded one;
  ``http_over_inprocess_by_mode`` has both (the embedded broker and result backend are polled SQLite).
- optimization_wall_s (not with --quick): a fresh service, basis (25 samples) + training at 5 Machs +
  the paper's DE (Np = 30, 150 generations = 4 530 structures) over HTTP, end to end.
``--all`` adds the other benchmark scripts' JSON (bench_modal, bench_projection, bench_training,
bench_dlm, bench_flutter, scaling). Progress goes to stderr. Timings depend on the machine's load: it is reported.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core, before numpy loads its BLAS

import argparse  # noqa: E402
import importlib.util  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
MACHS = (0.79, 0.83, 0.87, 0.91, 0.95)
EVAL_MAC = 0.9999  # the evaluations' fit criterion (only a note on a structure whose modes fit worse)
TRAIN_OPTIONS = {"reduce_order": "auto"}  # uvlm ROMs of the examples: balanced truncation at training
SOLVER = {"name": "dlm"}  # the aerodynamic solver of the in-process ROMs (``--solver``; the service's default)


def _ident() -> dict[str, Any]:
    """ROM identity of the in-process models (the UVLM's ARX ROMs reduced by balanced truncation)."""
    from romams.services.training import rom_identity

    name = SOLVER["name"]
    return rom_identity(name, options=TRAIN_OPTIONS if name == "uvlm" else None)
TARGETS = {"structure_eval_ms": 20.0, "batched_structure_ms": 5.0, "de_4530_http_s": 60.0,
           "worker_rss_growth_pct": 10.0, "optimization_wall_s": 600.0, "training_s_per_mach": 60.0}


def log(msg: str) -> None:
    """Progress on stderr."""
    print(f"[bench] {msg}", file=sys.stderr, flush=True)


def load_example(name: str) -> Any:
    """A script of examples/ as a module."""
    spec = importlib.util.spec_from_file_location(name, ROOT / "examples" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)  # type: ignore[union-attr]
    return mod


# ---- in process ---------------------------------------------------------------------------------------
def build_models(samples: int = 25, machs: tuple[float, ...] = MACHS, modes: int = 4, max_basis: int = 8,
                 mac_threshold: float = 0.9999) -> dict[str, Any]:
    """Cropped-delta basis (``samples`` x ``modes`` snapshots, MAC ``mac_threshold``, at most ``max_basis``
    shapes) and ROMs (``SOLVER``) at ``machs``, in process, with their timings (s)."""
    from romams.services.training import train
    from romams_core.basis import build_basis_for_wing
    from romams_core.mesh import standard_mesh
    from romams_core.wing import template

    wing = template("cropped-delta")
    mesh = standard_mesh(wing.planform)
    t0 = time.perf_counter()
    basis = build_basis_for_wing(wing, samples=samples, modes=modes, mac_threshold=mac_threshold,
                                 max_basis=max_basis, seed=0)
    t_basis = time.perf_counter() - t0
    roms, t_train = {}, []
    for m in machs:
        t0 = time.perf_counter()
        roms[float(m)] = train(mesh, basis.shapes, float(m), _ident())
        t_train.append(time.perf_counter() - t0)
    return {"wing": wing, "mesh": mesh, "basis": basis, "roms": roms, "basis_s": t_basis, "train_s": t_train,
            "modes": modes}


def eig_calibration_ms(n_matrices: int = 40, repeats: int = 5) -> float:
    """Median CPU time (ms) of numpy.linalg.eigvals on a fixed seeded set of 40 x 40 real matrices: the unit
    against which the evaluation times are reported as machine-independent ratios."""
    mats = np.random.default_rng(12345).normal(size=(n_matrices, 40, 40))
    np.linalg.eigvals(mats[0])  # warm-up
    times = []
    for _ in range(repeats):  # a few passes over the set
        for a in mats:
            t0 = time.process_time()
            np.linalg.eigvals(a)
            times.append(time.process_time() - t0)
    return 1e3 * float(np.median(times))


def structure_eval(models: dict[str, Any], n_designs: int, seed: int = 1) -> dict[str, Any]:
    """Median time of modal analysis + ROM-AMS flutter evaluation at every Mach of one structure (ms)."""
    from romams_core.basis import random_designs
    from romams_core.evaluate import evaluate_structure
    from romams_core.structure.modal import modal_analysis

    wing, mesh, basis, roms = models["wing"], models["mesh"], models["basis"], models["roms"]
    designs = random_designs(wing, n_designs + 1, seed=seed)
    zeta = wing.modal_damping or None
    k = models.get("modes", 4)
    evaluate_structure(modal_analysis(wing, designs[0], k, mesh), basis.shapes, roms, zeta=zeta)  # warm-up
    modal_ms, flutter_ms, total_ms, wall_ms = [], [], [], []
    for x in designs[1:]:
        w0, t0 = time.perf_counter(), time.process_time()
        modal = modal_analysis(wing, x, k, mesh)
        t1 = time.process_time()
        evaluate_structure(modal, basis.shapes, roms, mac_threshold=EVAL_MAC, zeta=zeta)
        t2, w2 = time.process_time(), time.perf_counter()
        modal_ms.append(1e3 * (t1 - t0))
        flutter_ms.append(1e3 * (t2 - t1))
        total_ms.append(1e3 * (t2 - t0))
        wall_ms.append(1e3 * (w2 - w0))
    return {"structure_eval_ms": float(np.median(total_ms)), "p90_ms": float(np.percentile(total_ms, 90)),
            "clock": "CPU time of this single-threaded process (the machine is shared; wall below)",
            "wall_ms_median": float(np.median(wall_ms)),
            "modal_ms": float(np.median(modal_ms)), "flutter_all_machs_ms": float(np.median(flutter_ms)),
            "n_designs": n_designs, "machs": sorted(roms), "n_basis": int(basis.n_basis),
            "rom_states": [int(r.ss.n_states) for _, r in sorted(roms.items())],
            "basis_s": models["basis_s"], "training_s_per_mach": models["train_s"]}


def batched_structure(models: dict[str, Any], n_batches: int, batch: int = 30, seed: int = 3) -> dict[str, Any]:
    """One structure inside a batch of ``batch`` (a DE generation): modal analysis per design, then the flutter
    searches of the whole batch at every Mach together (``evaluate_structures``), without the V-g checks after
    the crossing, as a DE chunk that keeps no V-g data runs them (``worker.evaluation.flutter_chunk``); CPU time of
    one core per batch over ``batch``, median over ``n_batches`` batches (ms). Also the full eigen-solves per search
    (per Mach), and the same with the V-g checks (``eigen_solves_per_mach_vg_checks``)."""
    from romams_core.basis import random_designs
    from romams_core.evaluate import evaluate_structures
    from romams_core.flutter import batch as flutter_batch_mod
    from romams_core.structure.modal import modal_analysis

    wing, mesh, basis, roms = models["wing"], models["mesh"], models["basis"], models["roms"]
    zeta = wing.modal_damping or None
    designs = random_designs(wing, batch * (n_batches + 1), seed=seed)
    per, modal_ms, wall, solves, solves_vg = [], [], [], [], []
    for b in range(n_batches + 1):  # the first batch warms up
        chunk = designs[b * batch:(b + 1) * batch]
        stats = flutter_batch_mod.STATS
        stats.reset()
        w0, t0 = time.perf_counter(), time.process_time()
        modals = [modal_analysis(wing, x, models.get("modes", 4), mesh) for x in chunk]
        t1 = time.process_time()
        evaluate_structures(modals, basis.shapes, roms, mac_threshold=EVAL_MAC, zeta=zeta,
                            flutter_options={"vg_checks": False})
        t2, w2 = time.process_time(), time.perf_counter()
        if b:
            per.append(1e3 * (t2 - t0) / batch)
            modal_ms.append(1e3 * (t1 - t0) / batch)
            wall.append(1e3 * (w2 - w0) / batch)
            solves.append(stats.matrices / (batch * len(roms)))
            stats.reset()  # the same batch with the V-g checks: its solves only (not timed)
            evaluate_structures(modals, basis.shapes, roms, mac_threshold=EVAL_MAC, zeta=zeta)
            solves_vg.append(stats.matrices / (batch * len(roms)))
    return {"batched_structure_ms": float(np.median(per)), "modal_ms": float(np.median(modal_ms)),
            "flutter_all_machs_ms": float(np.median(per) - np.median(modal_ms)),
            "wall_ms_median": float(np.median(wall)), "batch": batch, "n_batches": n_batches,
            "eigen_solves_per_mach": float(np.mean(solves)),
            "eigen_solves_per_mach_vg_checks": float(np.mean(solves_vg)), "vg_checks": False,
            "clock": "CPU time of this single-threaded process over the batch / batch size"}


def _rss_mb() -> float:
    """Resident set size (VmRSS, MB) of this process."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    return math.nan


def rss_growth(models: dict[str, Any], n_designs: int, seed: int = 4) -> dict[str, Any]:
    """RSS growth (%) of this process evaluating ``n_designs`` random designs in chunks, as a worker's flutter_chunk
    does (the evaluation use case ``evaluate_designs_summary``, chunks of the service's ``batch_chunk``): VmRSS after
    the first chunk (caches warm) against after the last. The worker's own LRU result cache (bounded by
    ``result_cache_size``) is not part of it."""
    from romams.services.evaluation import Models, evaluate_designs_summary
    from romams.settings import Settings
    from romams_core.basis import random_designs

    chunk = int(Settings().batch_chunk)
    ev = Models(0, models["wing"], models["mesh"], 0, models["basis"],
                {m: (i, r) for i, (m, r) in enumerate(sorted(models["roms"].items()))})
    cache: dict[Any, Any] = {}

    def memo(key: Any, load: Any) -> Any:
        if key not in cache:
            cache[key] = load()
        return cache[key]

    designs = random_designs(models["wing"], n_designs, seed=seed).tolist()
    rss, errors = [], 0
    t0 = time.perf_counter()
    for i in range(0, n_designs, chunk):
        out = evaluate_designs_summary(ev, designs[i:i + chunk], cache=memo)
        errors += sum("error" in r for r in out)
        rss.append(_rss_mb())
    base = rss[0]
    return {"worker_rss_growth_pct": 100.0 * (rss[-1] - base) / base, "rss_mb_after_first_chunk": base,
            "rss_mb_end": rss[-1], "rss_mb_max": max(rss), "n_designs": n_designs, "chunk": chunk,
            "errors": errors, "wall_s": time.perf_counter() - t0}


def rom_pms_cost(models: dict[str, Any], n_designs: int, ams_ms: float, seed: int = 2) -> dict[str, Any]:
    """ROM-PMS per structure (own-mode training at every Mach + flutter) vs ROM-AMS, and their flutter speeds."""
    from romams.services.training import train
    from romams_core.basis import random_designs
    from romams_core.evaluate import evaluate_structure
    from romams_core.structure.modal import modal_analysis

    wing, mesh, basis, roms = models["wing"], models["mesh"], models["basis"], models["roms"]
    zeta = wing.modal_damping or None
    times, errors, rows = [], [], []
    for x in random_designs(wing, n_designs, seed=seed):
        t0 = time.process_time()
        modal = modal_analysis(wing, x, 4, mesh)
        own = {m: train(mesh, modal.shapes, m, _ident()) for m in roms}
        pms = evaluate_structure(modal, modal.shapes, own, zeta=zeta)
        times.append(time.process_time() - t0)
        ams = evaluate_structure(modal, basis.shapes, roms, zeta=zeta)
        for a, p in zip(ams.flutter, pms.flutter, strict=True):
            if a.flutter_found and p.flutter_found:  # speed error as EAS, i.e. sqrt of the q_f ratio
                errors.append(100.0 * (math.sqrt(a.q_flutter_pa / p.q_flutter_pa) - 1.0))
            rows.append({"mach": float(a.mach), "q_ams_pa": a.q_flutter_pa if a.flutter_found else None,
                         "q_pms_pa": p.q_flutter_pa if p.flutter_found else None})
    pms_ms = 1e3 * float(np.median(times))
    err = np.abs(np.array(errors)) if errors else np.array([math.nan])
    return {"rom_pms_over_rom_ams": pms_ms / ams_ms, "rom_pms_ms": pms_ms, "rom_ams_ms": ams_ms,
            "n_designs": n_designs, "v_error_pct_median": float(np.median(err)), "v_error_pct_max": float(np.max(err)),
            "rows": rows}


# ---- over HTTP ------------------------------------------------------------------------------------------
def _vm_hwm_mb(pids: list[int]) -> list[float]:
    """Peak resident set size (VmHWM, MB) of each process."""
    out = []
    for pid in pids:
        try:
            for line in Path(f"/proc/{pid}/status").read_text().splitlines():
                if line.startswith("VmHWM:"):
                    out.append(int(line.split()[1]) / 1024.0)
        except OSError:
            continue
    return out


def _cpu_s(pids: list[int]) -> float:
    """User + system CPU seconds used so far by the processes ``pids``."""
    tick = os.sysconf("SC_CLK_TCK")
    total = 0.0
    for pid in pids:
        try:
            fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
            total += (int(fields[11]) + int(fields[12])) / tick
        except (OSError, IndexError, ValueError):
            continue
    return total


def _prepare(client: Any, samples: int, machs: tuple[float, ...]) -> tuple[int, dict[str, float]]:
    """Wing, basis and ROMs on the service (reused when present); setup timings."""
    ex = load_example("optimize_cropped_delta")
    t0 = time.perf_counter()
    wid = ex.prepare_service(client, "cropped-delta", machs, samples, 0, _ident()["options"], log=log, progress=False,
                             solver=SOLVER["name"])
    return wid, {"setup_s": time.perf_counter() - t0}


def service_throughput(data_dir: Path, workers: int, n_batch: int, samples: int, seed: int, **settings: Any
                       ) -> dict[str, Any]:
    """Designs/s of one batch request of ``n_batch`` random designs on a live service with ``workers`` processes
    (``settings``: ROMAMS_* settings of the service, e.g. database_url and broker_url)."""
    from benchmarks.live_service import LiveService
    from client import RomamsClient

    with LiveService(data_dir, concurrency=workers, **settings) as svc, RomamsClient(svc.url, timeout=600) as client:
        wid, setup = _prepare(client, samples, MACHS)
        info = client.get_wing(wid)
        lo = np.array([v["lower"] for v in info["design_variables"]])
        hi = np.array([v["upper"] for v in info["design_variables"]])
        rng = np.random.default_rng(seed)
        client.evaluate_batch(wid, lo + rng.random((4 * workers, lo.size)) * (hi - lo))  # load the models
        x = lo + rng.random((n_batch, lo.size)) * (hi - lo)
        load0 = os.getloadavg()[0]
        pids = svc.session_pids()
        cpu0 = _cpu_s(pids)
        t0 = time.perf_counter()
        res = client.evaluate_batch(wid, x, timeout_s=3600)
        dt = time.perf_counter() - t0
        cpu = _cpu_s(pids) - cpu0
        rss = _vm_hwm_mb(svc.worker_pids())
        api_rss = _vm_hwm_mb([svc.proc.pid])
    failed = sum("error" in r for r in res)
    return {"workers": workers, "n_designs": n_batch, "seconds": dt, "designs_per_s": n_batch / dt,
            "ms_per_design": 1e3 * dt / n_batch, "service_cpu_ms_per_design": 1e3 * cpu / n_batch,
            "errors": failed, "worker_peak_rss_mb": max(rss) if rss else None,
            "worker_processes_rss_mb": rss, "api_peak_rss_mb": api_rss[0] if api_rss else None,
            "load_avg_1min_before": load0, **setup}


def _fresh_pg_database() -> tuple[str, Any] | None:
    """(SQLAlchemy URL, drop callback) of a new PostgreSQL database at 127.0.0.1:5432, or None if unreachable."""
    try:
        import psycopg

        admin = psycopg.connect("postgresql://postgres@127.0.0.1:5432/test", autocommit=True, connect_timeout=3)
    except Exception:  # noqa: BLE001 - no server: the distributed variant is skipped
        return None
    name = f"romams_bench_{os.getpid()}_{int(time.time())}"
    admin.execute(f'CREATE DATABASE "{name}"')

    def drop() -> None:
        admin.execute(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')
        admin.close()

    return f"postgresql+psycopg://postgres@127.0.0.1:5432/{name}", drop


def _redis_url() -> str | None:
    """A Redis URL (database 15, flushed) at 127.0.0.1:6379, or None if unreachable."""
    try:
        import redis

        r = redis.Redis.from_url("redis://127.0.0.1:6379/15", socket_connect_timeout=3)
        r.ping()
        r.flushdb()
    except Exception:  # noqa: BLE001
        return None
    return "redis://127.0.0.1:6379/15"


def http_latency(data_dir: Path, samples: int, n_designs: int, seed: int = 21, **settings: Any) -> dict[str, Any]:
    """One synchronous evaluation over HTTP vs the same work in process (the use case on the same stored models).

    A live service (API + one evaluation worker process) with ``settings``; the same designs in process and over
    HTTP, each new to the worker (no cached answer), ``store`` false on both sides (same work). Medians of wall
    times (ms); ``http_over_inprocess`` is the ratio of the medians.
    """
    import httpx

    from benchmarks.live_service import LiveService
    from client import RomamsClient
    from romams.persistence import open_store
    from romams.services.evaluation import evaluate_structure_summary
    from romams.services.models import load_models, resolve_basis_id, trained_rom_ids
    from romams.settings import Settings
    from romams_core.basis import random_designs
    from romams_core.mesh import standard_mesh

    db_settings = Settings(data_dir=data_dir, **{k: v for k, v in settings.items() if k != "broker_url"})
    store = open_store(db_settings, migrate=True)  # a server database is migrated once, as `alembic upgrade head`
    with LiveService(data_dir, concurrency=1, **settings) as svc, RomamsClient(svc.url, timeout=600) as client:
        wid, setup = _prepare(client, samples, MACHS)
        wing_id, wing = store.wings.find(wid)
        bid = resolve_basis_id(store, wing_id)
        models = load_models(wing_id, wing, bid, trained_rom_ids(store, wing_id, bid), store.bases.load,
                             store.roms.load, lambda _: standard_mesh(wing.planform))
        designs = random_designs(wing, n_designs + 2, seed=seed).tolist()
        cache: dict[Any, Any] = {}

        def memo(key: Any, load: Any) -> Any:
            if key not in cache:
                cache[key] = load()
            return cache[key]

        # the same designs both ways (the worker has not seen them: no cached answer), warm-ups excluded; the two
        # measurements of a design are taken back to back, so a slow spell of the shared machine hits both
        evaluate_structure_summary(models, design=designs[0], cache=memo)  # warm-up (baseline, caches)
        local, remote = [], []
        with httpx.Client(base_url=svc.url, timeout=120) as http:
            assert http.post(f"/api/v1/wings/{wid}/flutter", json={"design": designs[1], "store": False}
                             ).status_code == 200  # warm-up: the worker loads the models
            for d in designs[2:]:
                t0 = time.perf_counter()
                evaluate_structure_summary(models, design=d, cache=memo)
                local.append(time.perf_counter() - t0)
                t0 = time.perf_counter()
                r = http.post(f"/api/v1/wings/{wid}/flutter", json={"design": d, "store": False})
                remote.append(time.perf_counter() - t0)
                if r.status_code != 200:
                    raise RuntimeError(f"evaluation failed: {r.status_code} {r.text[:300]}")
    ms_local, ms_http = 1e3 * float(np.median(local)), 1e3 * float(np.median(remote))
    ratios = np.asarray(remote) / np.asarray(local)
    return {"in_process_ms_median": ms_local, "http_ms_median": ms_http, "http_over_inprocess": ms_http / ms_local,
            "per_design_ratio_median": float(np.median(ratios)),
            "in_process_ms": [round(1e3 * x, 2) for x in local], "http_ms": [round(1e3 * x, 2) for x in remote],
            "http_ms_p90": 1e3 * float(np.percentile(remote, 90)), "n_designs": n_designs, "machs": list(MACHS),
            "n_basis": int(models.basis.n_basis), **setup}


def optimization(data_dir: Path, generations: int, popsize: int, workers: int = 2) -> dict[str, Any]:
    """End to end: fresh service, basis + training at 5 Machs, then the paper's DE over HTTP."""
    from benchmarks.live_service import LiveService
    from client import FlutterProblem, RomamsClient

    ex = load_example("optimize_cropped_delta")
    with LiveService(data_dir, concurrency=workers) as svc, RomamsClient(svc.url, timeout=600) as client:
        t0 = time.perf_counter()
        wid, setup = _prepare(client, 25, MACHS)
        problem = FlutterProblem(client, wid, machs=MACHS, mu=10.0, keep_history=False)
        baseline = problem.baseline()
        last = [0.0]

        def progress(msg: str) -> None:
            if time.perf_counter() - last[0] > 30:
                last[0] = time.perf_counter()
                log(msg)

        pids = svc.session_pids()
        cpu0 = _cpu_s(pids)
        run = ex.run_de(problem, generations, popsize, seed=0, log=progress)
        total = time.perf_counter() - t0
        cpu = _cpu_s(pids) - cpu0
    gen_s = np.diff([h["wall_s"] for h in run["history"]])
    return {"optimization_wall_s": total, "setup_s": setup["setup_s"], "de_s": run["wall_s"],
            "evaluations": run["nfev"], "batch_requests": run["batch_requests"], "generations": generations,
            "popsize": popsize, "workers": workers,
            "generation_s_median": float(np.median(gen_s)) if gen_s.size else None,
            "best_mass_kg": run["best"]["mass_kg"], "best_feasible": run["best"]["feasible"],
            "baseline_mass_kg": baseline["mass_kg"], "designs_per_s": run["nfev"] / run["wall_s"],
            "service_cpu_s_during_de": cpu, "load_avg_end": list(os.getloadavg())}


def sub_benchmarks() -> dict[str, Any]:
    """JSON of the other benchmark scripts (each run as its own process)."""
    out: dict[str, Any] = {}
    for name, args in (("bench_modal", []), ("bench_projection", []), ("bench_training", []),
                       ("bench_dlm", []), ("bench_flutter", []), ("scaling", [])):
        if not (ROOT / "benchmarks" / f"{name}.py").exists():
            continue
        log(f"running benchmarks.{name}")
        p = subprocess.run([sys.executable, "-m", f"benchmarks.{name}", *args], cwd=ROOT, capture_output=True,
                           text=True, timeout=1800)
        try:
            out[name] = json.loads(p.stdout)
        except json.JSONDecodeError:
            out[name] = {"error": (p.stderr or p.stdout)[-500:], "returncode": p.returncode}
    return out


def batched_keys(out: dict[str, Any], models: dict[str, Any], quick: bool) -> None:
    """batched_structure_ms, batched_over_eig (needs eig_calibration_ms in ``out``) and worker_rss_growth_pct."""
    bs = batched_structure(models, n_batches=2 if quick else 5)
    out["batched_structure_ms"] = bs["batched_structure_ms"]
    out["batched_over_eig"] = bs["batched_structure_ms"] / out["eig_calibration_ms"]
    out["batched_structure"] = bs
    log(f"batched_structure_ms = {bs['batched_structure_ms']:.1f}, {bs['eigen_solves_per_mach']:.1f} eigen-solves "
        "per Mach")
    rg = rss_growth(models, n_designs=640 if quick else 10_000)
    out["worker_rss_growth_pct"] = rg["worker_rss_growth_pct"]
    out["worker_rss"] = rg
    log(f"worker_rss_growth_pct = {rg['worker_rss_growth_pct']:.2f} over {rg['n_designs']} designs")


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Run the benchmarks and print one JSON object."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smaller samples, no full optimization")
    ap.add_argument("--json", action="store_true", help="compact JSON (default: indented)")
    ap.add_argument("--all", action="store_true", help="also run and include the other benchmark scripts")
    ap.add_argument("--generations", type=int, default=150, help="DE generations of the optimization benchmark")
    ap.add_argument("--popsize", type=int, default=30)
    ap.add_argument("--skip-service", action="store_true", help="in-process numbers only")
    ap.add_argument("--solver", default="dlm", choices=["dlm", "uvlm"], help="solver of the in-process ROMs")
    args = ap.parse_args(argv)
    quick = args.quick
    t_start = time.perf_counter()
    out: dict[str, Any] = {"benchmark": "romams", "quick": quick, "targets": TARGETS,
                           "machine": {"cpus": os.cpu_count(), "python": platform.python_version(),
                                       "numpy": np.__version__, "load_avg_start": list(os.getloadavg())}}
    SOLVER["name"] = args.solver
    out["solver"] = args.solver
    log(f"in process: basis + {args.solver} ROMs at 5 Machs")
    models = build_models(samples=25)
    se = structure_eval(models, n_designs=10 if quick else 40)
    out["structure_eval_ms"] = se["structure_eval_ms"]
    out["eig_calibration_ms"] = eig_calibration_ms()
    out["structure_eval_over_eig"] = se["structure_eval_ms"] / out["eig_calibration_ms"]
    out["structure_eval"] = se
    log(f"structure_eval_ms = {se['structure_eval_ms']:.1f}")
    batched_keys(out, models, quick)
    pms = rom_pms_cost(models, n_designs=1 if quick else 3, ams_ms=se["structure_eval_ms"])
    out["rom_pms_over_rom_ams"] = pms["rom_pms_over_rom_ams"]
    out["rom_pms"] = pms
    log(f"rom_pms_over_rom_ams = {pms['rom_pms_over_rom_ams']:.1f}")
    if not args.skip_service:
        with tempfile.TemporaryDirectory(prefix="romams-bench-") as tmp:
            data = Path(tmp) / "svc"
            runs = []
            for workers, n in ((1, 100 if quick else 300), (2, 200 if quick else 1000)):
                log(f"service with {workers} worker(s): batch of {n} designs")
                runs.append(service_throughput(data, workers, n, samples=25, seed=10 + workers))
                log(f"  {runs[-1]['designs_per_s']:.1f} designs/s, worker peak RSS {runs[-1]['worker_peak_rss_mb']} MB")
            out["batch_throughput_per_s"] = {str(r["workers"]): r["designs_per_s"] for r in runs}
            out["worker_peak_rss_mb"] = runs[-1]["worker_peak_rss_mb"]
            out["worker_peak_rss_batch"] = runs[-1]["n_designs"]
            out["service"] = runs
            log("single synchronous evaluation: HTTP (embedded service) vs in process")
            lat = {"embedded": http_latency(Path(tmp) / "lat", samples=25, n_designs=10 if quick else 30)}
            pg, redis_url = _fresh_pg_database(), _redis_url()
            if pg is not None and redis_url is not None:
                log("single synchronous evaluation: HTTP (PostgreSQL + Redis) vs in process")
                try:
                    lat["distributed"] = http_latency(Path(tmp) / "lat-pg", samples=25,
                                                      n_designs=10 if quick else 30, database_url=pg[0],
                                                      broker_url=redis_url)
                finally:
                    pg[1]()
            # the headline is the distributed deployment (PostgreSQL + Redis, as docker-compose runs it) when its
            # servers answer; the embedded mode (SQLite broker and results, polled) is reported next to it
            mode = "distributed" if "distributed" in lat else "embedded"
            out["http_over_inprocess"] = lat[mode]["http_over_inprocess"]
            out["http_over_inprocess_mode"] = mode
            out["http_over_inprocess_by_mode"] = {k: v["http_over_inprocess"] for k, v in lat.items()}
            out["single_evaluation"] = lat
            log("http_over_inprocess = " + ", ".join(f"{k} {v['http_over_inprocess']:.2f}" for k, v in lat.items()))
            if not quick:
                log(f"optimization: fresh service, DE {args.popsize} x {args.generations} generations")
                opt = optimization(Path(tmp) / "opt", args.generations, args.popsize)
                out["optimization_wall_s"] = opt["optimization_wall_s"]
                out["de_4530_http_s"] = opt["de_s"]  # the DE alone (setup excluded); 4 530 structures by default
                out["optimization"] = opt
                log(f"optimization_wall_s = {opt['optimization_wall_s']:.1f}")
    if args.all:
        out["sub_benchmarks"] = sub_benchmarks()
    out["machine"]["load_avg_end"] = list(os.getloadavg())
    out["wall_s"] = time.perf_counter() - t_start
    print(json.dumps(out, separators=(",", ":") if args.json else None, indent=None if args.json else 1,
                     default=float))
    return out


if __name__ == "__main__":
    main()
