"""Training time per Mach number (UVLM "CFD" run + ARX identification) on the cropped delta wing; prints JSON.

Default mesh (the wing's standard mesh), default signal length and dt_star = 1 / n_chord, na = nb = 8, on the
wing's PCA basis built with ``--mac`` (0.98: the pipeline default; 0.9999 gives the paper's 8 shapes).
Target: <= 60 s per Mach on 2 cores. ``--blas-threads N`` sets OPENBLAS/OMP thread counts before numpy loads
(on a shared 2-core machine 1 thread is several times faster for these small matrices).

Usage: python -m benchmarks.bench_training [--mac 0.98] [--reduce auto] [--blas-threads 1]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time


def main() -> None:
    """Run the benchmark and print one JSON object."""
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--wing", default="cropped-delta")
    ap.add_argument("--machs", default="0.79,0.83,0.87,0.91,0.95")
    ap.add_argument("--mac", type=float, default=0.98, help="basis MAC threshold")
    ap.add_argument("--reduce", default=None, help="reduce_order: 'auto' or an integer")
    ap.add_argument("--blas-threads", type=int, default=None)
    args = ap.parse_args()
    if args.blas_threads is not None:
        if "numpy" in sys.modules:
            raise SystemExit("--blas-threads must be applied before numpy is imported")
        for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
            os.environ[var] = str(args.blas_threads)

    import numpy as np

    from romams_core.aero.uvlm import UvlmSolver
    from romams_core.basis import build_basis_for_wing
    from romams_core.mesh import standard_mesh
    from romams_core.training import train_rom
    from romams_core.wing import template

    wing = template(args.wing)
    mesh = standard_mesh(wing.planform)
    t0 = time.perf_counter()
    basis = build_basis_for_wing(wing, samples=25, modes=4, mac_threshold=args.mac)
    basis_s = time.perf_counter() - t0
    reduce = args.reduce if args.reduce in (None, "auto") else int(args.reduce)
    solver = UvlmSolver()
    rows = []
    for mach in (float(m) for m in args.machs.split(",")):  # a handful of Mach numbers
        t0 = time.perf_counter()
        rom = train_rom(mesh, basis.shapes, mach, solver, reduce_order=reduce)
        wall = time.perf_counter() - t0
        rows.append({
            "mach": mach,
            "train_seconds": round(wall, 3),
            "solver_seconds": round(rom.solver_seconds, 3),
            "n_steps_total": int(rom.signals_train.shape[0] + rom.signals_validation.shape[0]),
            "n_states": rom.ss.n_states,
            "validation_nrmse_max": float(np.max(rom.validation_nrmse)),
            "warnings": len(rom.warnings),
        })
    times = [r["train_seconds"] for r in rows]
    print(json.dumps({
        "benchmark": "training",
        "wing": wing.name,
        "mesh_panels": [mesh.n_chord, mesh.n_span],
        "wake_chords": solver.wake_chords,
        "dt_star": 1.0 / mesh.n_chord,
        "n_basis": basis.n_basis,
        "na": 8,
        "nb": 8,
        "reduce_order": reduce,
        "blas_threads": os.environ.get("OPENBLAS_NUM_THREADS", "default"),
        "basis_seconds": round(basis_s, 3),
        "per_mach": rows,
        "train_seconds_max": max(times),
        "target_seconds": 60.0,
        "meets_target": max(times) <= 60.0,
    }))


if __name__ == "__main__":
    main()
