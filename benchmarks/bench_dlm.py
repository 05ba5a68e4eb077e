"""DLM training time per Mach number (AIC build, GAF table, RFA fit) on the cropped delta wing; prints JSON.

Default lattice (the standard mesh refined 2x: 20 x 28 boxes on the half wing, 560 boxes, mirrored explicitly),
the default 16-point reduced-frequency table, the wing's PCA basis at MAC 0.9999 (8 shapes, the paper's),
one BLAS thread (``--blas-threads``, set before numpy loads). Target: <= 60 s per Mach on one core.

Machine-independent ratio: ``dlm_over_uvlm`` = DLM training time / UVLM + ARX training time of the same shapes
at the same Mach (both on this machine, back to back), and ``fit_share`` = RFA fit time / DLM training time.

Usage: python -m benchmarks.bench_dlm [--machs 0.79,0.87,0.95] [--blas-threads 1] [--no-uvlm]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time


def main() -> None:
    """Run the benchmark and print one JSON object."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--machs", default="0.79,0.87,0.95")
    ap.add_argument("--blas-threads", type=int, default=1)
    ap.add_argument("--no-uvlm", action="store_true", help="skip the UVLM reference (no ratio)")
    args = ap.parse_args()
    if "numpy" in sys.modules:
        raise SystemExit("--blas-threads must be applied before numpy is imported")
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[var] = str(args.blas_threads)

    import numpy as np

    from romams_core.aero import dlm
    from romams_core.aero.uvlm import UvlmSolver
    from romams_core.basis import build_basis_for_wing
    from romams_core.mesh import standard_mesh
    from romams_core.training import train_rom
    from romams_core.training_rfa import train_rfa_rom
    from romams_core.wing import template

    wing = template("cropped-delta")
    mesh = standard_mesh(wing.planform)
    basis = build_basis_for_wing(wing, samples=25, modes=4, mac_threshold=0.9999, max_basis=8)
    rows = []
    for mach in (float(m) for m in args.machs.split(",")):  # a handful of Mach numbers
        dlm._SYSTEM_CACHE.clear()
        dlm._LU_CACHE.clear()  # a cold start: the AICs are built, as in a training job
        t0 = time.perf_counter()
        rom = train_rfa_rom(mesh, basis.shapes, mach, dlm.DlmSolver())
        wall = time.perf_counter() - t0
        row = {"mach": mach, "train_seconds": round(wall, 3), "solver_seconds": round(rom.solver_seconds, 3),
               "fit_seconds": round(wall - rom.solver_seconds, 3), "fit_share": round(1 - rom.solver_seconds / wall, 3),
               "n_k": int(rom.k_values.size), "n_lags": rom.n_lags, "n_complex_pairs": int(rom.rfa.pairs.size),
               "n_states": rom.ss.n_states, "fit_error_max": float(rom.max_fit_error)}
        if not args.no_uvlm:
            t0 = time.perf_counter()
            train_rom(mesh, basis.shapes, mach, UvlmSolver())
            uvlm = time.perf_counter() - t0
            row.update(uvlm_train_seconds=round(uvlm, 3), dlm_over_uvlm=round(wall / uvlm, 3))
        rows.append(row)
    train = np.array([r["train_seconds"] for r in rows])
    print(json.dumps({
        "benchmark": "dlm_training", "wing": wing.name, "n_basis": int(basis.n_basis),
        "boxes_half_wing": int(mesh.n_chord * mesh.n_span * dlm.DlmSolver().refine ** 2),
        "blas_threads": args.blas_threads, "target_s_per_mach": 60.0,
        "train_seconds_max": float(train.max()), "meets_target": bool(train.max() <= 60.0),
        "rows": rows,
    }))


if __name__ == "__main__":
    main()
