"""How the evaluation and training costs scale (issue 14's scaling figures), printed as ONE JSON object.

    python -m benchmarks.scaling [--quick] [--skip-service] [--json]

In process, one core, the cropped delta with ROMs of ``benchmarks.run``'s solver (DLM):
- ``structure_by_modes``: one structure (modal analysis of k modes + ROM-AMS flutter at the paper's 5 Machs),
  alone (``alone_ms``, median over designs) and inside a batch of 30 (``batched_ms``), for k = 4, 8, 12 on a
  basis of m = 12 shapes built from k-mode snapshots;
- ``structure_by_basis``: the same for basis sizes m = 5, 8, 12 (k = 4);
- ``structure_by_machs``: the same for 1, 5 and 10 Machs (k = 4, m = 8);
- ``training_by_basis``: the training of one ROM (seconds per Mach, median over the Machs) for m = 5, 8, 12.
Bases are built to exactly m shapes (the MAC criterion is set out of reach, so the size cap decides). Every time
comes with its ratio to ``eig_calibration_ms`` (``benchmarks.run``: numpy.linalg.eigvals of 40 x 40 matrices,
measured in this run), which does not depend on the machine's speed.

Over HTTP (not with ``--skip-service``), the distributed deployment (PostgreSQL and Redis at 127.0.0.1, as in
CI; skipped with a reason when they do not answer): ``throughput_by_workers``, designs/s of one
POST /flutter/batch request on ``romams serve`` with 1, 2 and 4 worker processes (the same database: the basis
and ROMs are trained once), with the service's CPU time per design. The machine's core count is reported: past
it, more processes cannot add throughput.

``--quick``: fewer designs (5 alone, one batch of 30; 120 designs per batch request). Progress goes to stderr.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core, before numpy loads its BLAS

import argparse  # noqa: E402
import json  # noqa: E402
import statistics  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

from benchmarks import run as bench  # noqa: E402

PAPER_MACHS = bench.MACHS
TEN_MACHS = (0.5, 0.6, 0.7, 0.75, 0.79, 0.83, 0.85, 0.87, 0.91, 0.95)
FORCE_SIZE = 1.0 - 1e-12  # a MAC criterion no basis meets: the basis has exactly max_basis shapes
MODES, BASES, WORKERS = (4, 8, 12), (5, 8, 12), (1, 2, 4)


def log(msg: str) -> None:
    """Progress on stderr."""
    bench.log(f"scaling: {msg}")


def point(models: dict[str, Any], eig_ms: float, quick: bool, machs: tuple[float, ...] | None = None
          ) -> dict[str, Any]:
    """Alone and batched cost of one structure on ``models`` (restricted to ``machs``), with the ratios."""
    if machs is not None:
        models = {**models, "roms": {m: models["roms"][m] for m in machs}}
    alone = bench.structure_eval(models, n_designs=5 if quick else 20)
    batched = bench.batched_structure(models, n_batches=1 if quick else 3)
    return {"modes": models["modes"], "n_basis": int(models["basis"].n_basis), "machs": len(models["roms"]),
            "rom_states": [int(r.ss.n_states) for _, r in sorted(models["roms"].items())],
            "alone_ms": round(alone["structure_eval_ms"], 2), "alone_modal_ms": round(alone["modal_ms"], 2),
            "alone_over_eig": round(alone["structure_eval_ms"] / eig_ms, 1),
            "batched_ms": round(batched["batched_structure_ms"], 2), "batched_modal_ms": round(batched["modal_ms"], 2),
            "batched_over_eig": round(batched["batched_structure_ms"] / eig_ms, 1),
            "eigen_solves_per_mach": round(batched["eigen_solves_per_mach"], 1)}


def in_process(quick: bool, eig_ms: float, modes: tuple[int, ...] = MODES, bases: tuple[int, ...] = BASES,
               samples: int = 25) -> dict[str, Any]:
    """The structure and training scaling keys (in process): the k sweep on the largest basis, the m sweep with
    4 modes, the Mach sweep (1, 5, 10 Machs) on the middle basis."""
    big, mid = max(bases), sorted(bases)[len(bases) // 2]
    models_by: dict[tuple[int, int], dict[str, Any]] = {}
    for k, m in dict.fromkeys([(4, b) for b in bases] + [(k, big) for k in modes]):
        machs = TEN_MACHS if (k, m) == (4, mid) else PAPER_MACHS
        log(f"basis of {m} shapes from {k}-mode snapshots, ROMs at {len(machs)} Machs")
        models_by[k, m] = bench.build_models(samples=samples, machs=machs, modes=k, max_basis=m,
                                             mac_threshold=FORCE_SIZE)
    points: dict[tuple[int, int, tuple[float, ...]], dict[str, Any]] = {}

    def at(k: int, m: int, machs: tuple[float, ...]) -> dict[str, Any]:
        """The point of (k, m, machs), measured once (the m sweep's largest basis is the k sweep's k = 4)."""
        if (k, m, machs) not in points:
            points[k, m, machs] = point(models_by[k, m], eig_ms, quick, machs)
        return points[k, m, machs]

    by_basis, training = [], []
    for m in bases:
        mod = models_by[4, m]
        t = statistics.median(t for mach, t in zip(sorted(mod["roms"]), mod["train_s"], strict=True)
                              if mach in PAPER_MACHS)
        training.append({"n_basis": int(mod["basis"].n_basis), "train_s_per_mach": round(t, 2),
                         "train_over_eig": round(1e3 * t / eig_ms)})
        by_basis.append(at(4, m, PAPER_MACHS))
        log(f"m = {m}: {by_basis[-1]['alone_ms']} ms alone, {by_basis[-1]['batched_ms']} ms batched; training "
            f"{t:.1f} s per Mach")
    by_modes = []
    for k in modes:
        by_modes.append(at(k, big, PAPER_MACHS))
        log(f"k = {k}: {by_modes[-1]['alone_ms']} ms alone, {by_modes[-1]['batched_ms']} ms batched")
    by_machs = []
    for machs in ((0.87,), PAPER_MACHS, TEN_MACHS):
        by_machs.append(at(4, mid, machs))
        log(f"{len(machs)} Machs: {by_machs[-1]['alone_ms']} ms alone, {by_machs[-1]['batched_ms']} ms batched")
    return {"structure_by_modes": by_modes, "structure_by_basis": by_basis, "structure_by_machs": by_machs,
            "training_by_basis": training}


def throughput(quick: bool) -> dict[str, Any]:
    """``throughput_by_workers`` on the distributed deployment (or the reason it was skipped)."""
    pg, redis_url = bench._fresh_pg_database(), bench._redis_url()
    if pg is None or redis_url is None:
        if pg is not None:
            pg[1]()
        return {"throughput_by_workers": None, "throughput_skipped": "PostgreSQL or Redis at 127.0.0.1 not reachable"}
    from romams.persistence import dispose_engines, open_store
    from romams.settings import Settings

    rows = []
    try:
        with tempfile.TemporaryDirectory(prefix="romams-scaling-") as tmp:
            open_store(Settings(data_dir=Path(tmp), database_url=pg[0]), migrate=True)  # `alembic upgrade head`
            dispose_engines()
            for w in WORKERS:
                log(f"distributed service, {w} worker process(es)")
                r = bench.service_throughput(Path(tmp), w, 120 if quick else 600, samples=25, seed=30 + w,
                                             database_url=pg[0], broker_url=redis_url)
                rows.append({"workers": w, "designs_per_s": round(r["designs_per_s"], 2),
                             "service_cpu_ms_per_design": round(r["service_cpu_ms_per_design"], 1),
                             "n_designs": r["n_designs"], "errors": r["errors"], "seconds": round(r["seconds"], 2),
                             "worker_peak_rss_mb": r["worker_peak_rss_mb"]})
                log(f"  {rows[-1]['designs_per_s']} designs/s")
    finally:
        pg[1]()
    base = rows[0]["designs_per_s"]
    for r in rows:
        r["speedup_over_one"] = round(r["designs_per_s"] / base, 2)
    return {"throughput_by_workers": rows, "cpus": os.cpu_count()}


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Run the sweeps and print the JSON object."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer designs")
    ap.add_argument("--skip-service", action="store_true", help="in-process sweeps only")
    ap.add_argument("--json", action="store_true", help="compact JSON (default: indented)")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    eig_ms = bench.eig_calibration_ms()
    out: dict[str, Any] = {"benchmark": "scaling", "quick": args.quick, "solver": bench.SOLVER["name"],
                           "eig_calibration_ms": round(eig_ms, 4), "load_avg_start": list(os.getloadavg())}
    out.update(in_process(args.quick, eig_ms))
    if not args.skip_service:
        out.update(throughput(args.quick))
    out["load_avg_end"] = list(os.getloadavg())
    out["wall_s"] = round(time.perf_counter() - t0, 1)
    print(json.dumps(out, separators=(",", ":")) if args.json else json.dumps(out, indent=1))
    return out


if __name__ == "__main__":
    main()
