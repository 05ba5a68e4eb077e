"""Is the TSD's trailing-edge step cap still needed? Perturbed rest states and step records at larger steps (JSON).

``TsdSolver.time_step`` caps the internal step at three trailing-edge cells (``te_cells_per_step``), because the
near-wake coupling is explicit: on the cropped delta (taper 0.2) dt 0.02 grew from a perturbed rest state. That
was measured before the wake delay was taken from the last wing node (docs/transonic.md 7.3). Here, on the
cropped delta's default grid (flat plate, so the rest state is the mean flow):

1. ``--machs`` x ``--substeps`` (internal steps per 0.1 t* signal step): random potential of 1e-4 on every node,
   marched ``--span`` t* with the product's sub-iterations; the growth of max |phi - mean phi| between the first
   and the last tenth of the run (below 1: decays);
2. ``--records``: basis shapes 1..n stepped alone (``anchors.step_anchors``, 120 t*) at each sub-step count, and
   their transfer columns at k 0.025-0.5 against those at the capped step (share of the largest entry).

    python -m benchmarks.tsd_step_cap [--machs 0.6 0.87 0.95] [--substeps 9 7 5] [--span 60] [--records 2]
"""

from __future__ import annotations

import argparse
import json
import time
from typing import Any

import numpy as np

from romams_core.aero.tsd.coefficients import tsd_coefficients
from romams_core.aero.tsd.flow import TsdFlow
from romams_core.aero.tsd.solver import TsdSolver
from romams_core.anchors import step_anchors
from romams_core.basis import build_basis_for_wing
from romams_core.mesh import standard_mesh
from romams_core.training_tsd import make_tsd_solver
from romams_core.wing import template

SIGNAL_DT = 0.1
K_CHECK = np.array([0.025, 0.05, 0.1, 0.2, 0.3, 0.5])


def solver_at(substeps: int) -> TsdSolver:
    """The product's TSD solver with the internal step set to SIGNAL_DT / substeps (cap lifted)."""
    solver = make_tsd_solver()
    solver.dt = SIGNAL_DT / substeps + 1e-12
    solver.te_cells_per_step = 1e9
    return solver


def perturbed_rest(mesh: Any, mach: float, substeps: int, span: float, seed: int = 0) -> dict[str, Any]:
    """Growth of a random 1e-4 potential over ``span`` t* at the step SIGNAL_DT / substeps."""
    solver = solver_at(substeps)
    grid = solver.build_grid(mesh)
    dt = solver.time_step(grid)
    flow = TsdFlow(grid, tsd_coefficients(mach, solver.coefficients), sponge_rate=solver.sponge_rate)
    flow.phi += 1e-4 * np.random.default_rng(seed).standard_normal(flow.phi.shape)
    flow.start_unsteady()
    n = int(round(span / dt))
    amp = np.empty(n)
    t0 = time.perf_counter()
    for i in range(n):
        flow.step(dt, solver.n_sub_at(mach))
        amp[i] = np.abs(flow.phi - flow.phi.mean()).max()
        if not np.isfinite(amp[i]) or amp[i] > 1.0:
            amp = amp[: i + 1]
            break
    tenth = max(1, n // 10)
    growth = float(amp[-tenth:].max() / amp[:tenth].max()) if np.all(np.isfinite(amp)) else float("inf")
    return {"mach": mach, "substeps": substeps, "dt": dt, "steps": int(amp.size), "completed": amp.size == n,
            "growth": growth, "final_amp": float(amp[-1]), "seconds": time.perf_counter() - t0}


def record_columns(mesh: Any, shapes: np.ndarray, mach: float, substeps: int) -> np.ndarray:
    """Step-record transfer [K_CHECK, m, m] of ``shapes`` at the step SIGNAL_DT / substeps."""
    return step_anchors(solver_at(substeps), mesh, shapes, mach, K_CHECK, SIGNAL_DT)


def run(machs: tuple[float, ...], substeps: tuple[int, ...], span: float, records: int) -> dict[str, Any]:
    """Both checks (module docstring); a JSON-able dict."""
    wing = template("cropped-delta")
    mesh = standard_mesh(wing.planform)
    capped = make_tsd_solver()
    res: dict[str, Any] = {"capped_dt": capped.time_step(capped.build_grid(mesh)), "rest": [], "records": []}
    for mach in machs if span > 0 else ():
        for n in substeps:
            res["rest"].append(perturbed_rest(mesh, mach, n, span))
            print(json.dumps(res["rest"][-1]), flush=True)
    if records:
        shapes = build_basis_for_wing(wing, samples=25, modes=4, mac_threshold=0.9999, max_basis=8).shapes
        shapes = shapes[:, :records]
        for mach in machs:
            ref = None
            for n in sorted(substeps, reverse=True):  # the finest step first: the reference
                t0 = time.perf_counter()
                g = record_columns(mesh, shapes, mach, n)
                row: dict[str, Any] = {"mach": mach, "substeps": n, "seconds": time.perf_counter() - t0}
                if ref is None:
                    ref = g
                else:
                    scale = np.abs(ref).max(axis=(1, 2))
                    row["err_of_max_pct"] = {f"{k:g}": float(100 * np.abs(g[i] - ref[i]).max() / scale[i])
                                             for i, k in enumerate(K_CHECK)}
                res["records"].append(row)
                print(json.dumps(row), flush=True)
    return res


def main() -> None:
    """CLI entry point."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--machs", type=float, nargs="+", default=[0.6, 0.87, 0.95])
    ap.add_argument("--substeps", type=int, nargs="+", default=[9, 7, 5])
    ap.add_argument("--span", type=float, default=60.0, help="t* marched from the perturbed rest state (0: skip)")
    ap.add_argument("--records", type=int, default=2, help="basis shapes stepped at each step (0: none)")
    a = ap.parse_args()
    print(json.dumps(run(tuple(a.machs), tuple(a.substeps), a.span, a.records)))


if __name__ == "__main__":
    main()
