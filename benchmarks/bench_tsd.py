"""TSD training cost per Mach on the cropped delta wing (8 PCA basis shapes, the paper's); prints JSON.

Reports the default grid (size, internal time step, steps), the steady mean-flow time and steps, the unsteady
run's time and steps, the ARX fit, and the whole training time per Mach, against the issue's target of
10 minutes per Mach for this case (the paper's Euler training took 1350 minutes on 8 cores).

The training and validation records are marched side by side, one thread each (``record_threads``), so
``unsteady_s`` is wall time for both records. Machine-independent ratios: ``us_per_point_step`` (wall
microseconds per grid point and time step, both records counted, unsteady run)
and ``training_over_dlm`` (TSD training time / DLM training time of the same shapes, same machine, back to back).

Since 2026-12-04 the training is anchored by default (docs/transonic.md 7.11): ``anchor_s`` is the step records'
share of ``training_s``; ``--anchor-k none`` times a plain training.

Usage: python -m benchmarks.bench_tsd [--machs 0.87] [--grid-scale 1.0] [--no-dlm] [--record-threads N]
           [--anchor-k none|K1 K2 ..]
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
    ap.add_argument("--machs", default="0.87")
    ap.add_argument("--grid-scale", type=float, default=1.0)
    ap.add_argument("--no-dlm", action="store_true", help="skip the DLM reference (no ratio)")
    ap.add_argument("--anchor-k", nargs="+", default=None, help="anchor k, or 'none' (a plain ROM; the "
                    "training's default anchors when not given)")
    ap.add_argument("--record-threads", type=int, default=None,
                    help="threads marching the training and validation records (default: one each, up to the cores)")
    args = ap.parse_args()
    if "numpy" in sys.modules:
        raise SystemExit("thread settings must be applied before numpy is imported")
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[var] = "1"

    import numpy as np

    from benchmarks.accuracy_rom_ams import anchor_options, anchor_value
    from romams.services.training import rom_identity, train
    from romams_core.basis import build_basis_for_wing
    from romams_core.mesh import standard_mesh
    from romams_core.training_tsd import make_tsd_solver, train_tsd_rom, tsd_n_steps
    from romams_core.wing import template

    wing = template("cropped-delta")
    mesh = standard_mesh(wing.planform)
    basis = build_basis_for_wing(wing, samples=25, modes=4, mac_threshold=0.9999, max_basis=8, seed=0)
    rows = []
    for mach in (float(m) for m in args.machs.split(",")):
        solver = make_tsd_solver(grid_scale=args.grid_scale)
        solver.record_threads = args.record_threads
        grid = solver.build_grid(mesh)
        t0 = time.perf_counter()
        anchors = anchor_options(None if args.anchor_k is None else [anchor_value(v) for v in args.anchor_k])
        rom = train_tsd_rom(mesh, basis.shapes, mach, solver, **anchors)
        total = time.perf_counter() - t0
        mf = solver.last_mean_flow
        assert mf is not None
        n_samples = 2 * tsd_n_steps(basis.n_basis, 8, 8, rom.dt_star)
        substeps = int(np.ceil(rom.dt_star / solver.time_step(grid) - 1e-9))
        unsteady_steps = n_samples * substeps
        unsteady_s = rom.solver_seconds - mf.steady.seconds
        row = {
            "mach": mach, "grid": list(grid.shape), "grid_points": grid.n_points, "n_basis": basis.n_basis,
            "dt": solver.time_step(grid), "n_sub": solver.n_sub_at(mach),
            "record_threads": solver.record_threads or min(2, len(os.sched_getaffinity(0))),
            "steady_steps": mf.steady.steps, "steady_converged": mf.steady.converged,
            "steady_s": round(mf.steady.seconds, 2),
            "unsteady_steps": unsteady_steps, "unsteady_s": round(unsteady_s, 2),
            "us_per_point_step": round(1e6 * unsteady_s / (unsteady_steps * grid.n_points), 4),
            "training_s": round(total, 2), "training_min": round(total / 60.0, 2), "target_min": 10.0,
            "validation_nrmse_max": float(np.max(rom.validation_nrmse)), "n_states": rom.ss.n_states,
            "anchor_k": None if rom.anchor_k is None else [float(k) for k in rom.anchor_k],
            "anchor_band_error": rom.anchor_band_error, "na": rom.na, "nb": rom.nb, "warnings": list(rom.warnings),
            # the step records of the anchors (one per shape, after the training records): the rest of the time
            "anchor_s": round(total - rom.train_seconds, 2), "plain_training_s": round(rom.train_seconds, 2),
        }
        if not args.no_dlm:
            t0 = time.perf_counter()
            train(mesh, basis.shapes, mach, rom_identity("dlm"))
            row["dlm_training_s"] = round(time.perf_counter() - t0, 2)
            row["training_over_dlm"] = round(total / row["dlm_training_s"], 2)
        rows.append(row)
    print(json.dumps({"case": "cropped-delta", "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
