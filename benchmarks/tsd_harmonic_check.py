"""Direct harmonic TSD GAF of a wing's own modes against the DLM at chosen reduced frequencies (prints JSON).

Each column is one run: the mode oscillates alone, at a peak displacement of 0.2 % of c_ref, with a one-period
ramp, and the last period is analysed. Used in docs/transonic.md section 7.3 to tell the TSD solver from its ROM
and to check the DLM's lattice and the TSD grid at high k.

    python -m benchmarks.tsd_harmonic_check [--wing agard-445.6] [--mach 0.7] [--k 0.2 0.95] [--columns 0 2]
        [--grid-scale 1.0] [--dlm-refine 2]
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np

from romams_core.aero.dlm import DlmSolver
from romams_core.mesh import standard_mesh
from romams_core.structure.modal import modal_analysis
from romams_core.training_tsd import make_tsd_solver
from romams_core.wing import template


def harmonic_column(solver, mesh, shapes: np.ndarray, mach: float, k: float, col: int) -> np.ndarray:  # noqa: ANN001
    """First-harmonic GAC column [m] (m^3 per unit generalized displacement) of shape ``col`` at k (c_ref / 2)."""
    dts, om = 0.1, 2.0 * k
    cycles = 3 if k > 0.5 else 2
    t = np.arange(int(round(cycles * 2 * math.pi / om / dts)) + 1) * dts
    ramp = np.minimum(1.0, t / (2 * math.pi / om))
    last = t >= t[-1] - 2 * math.pi / om
    e = np.exp(-1j * om * t[last])
    sig = np.zeros((t.size, shapes.shape[1]))
    sig[:, col] = 0.002 * mesh.c_ref / np.abs(shapes[:, col]).max() * np.sin(om * t) * ramp
    gac = solver.simulate(mesh, shapes, sig, mach, dts)
    return (gac[last] * e[:, None]).sum(0) / (sig[last, col] * e).sum()


def main() -> None:
    """Run the harmonic columns and print the ratios to the DLM's GAF."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--wing", default="agard-445.6")
    ap.add_argument("--mach", type=float, default=0.7)
    ap.add_argument("--k", type=float, nargs="+", default=[0.2, 0.95])
    ap.add_argument("--columns", type=int, nargs="+", default=[0, 2])
    ap.add_argument("--grid-scale", type=float, default=1.0)
    ap.add_argument("--dlm-refine", type=int, default=2)
    a = ap.parse_args()
    wing = template(a.wing)
    mesh = standard_mesh(wing.planform)
    shapes = modal_analysis(wing, None, 4, mesh).shapes
    solver = make_tsd_solver(grid_scale=a.grid_scale)  # flat: the linear limit
    rows = []
    for k in a.k:
        dlm = DlmSolver(refine=a.dlm_refine).gaf(mesh, shapes, a.mach, np.array([k]))[0]
        for col in a.columns:
            h = harmonic_column(solver, mesh, shapes, a.mach, k, col)
            ratio = h[col] / dlm[col, col]
            rows.append({"k": k, "column": col, "magnitude_ratio": float(abs(ratio)),
                         "phase_deg": float(np.degrees(np.angle(ratio)))})
    print(json.dumps({"wing": a.wing, "mach": a.mach, "grid_scale": a.grid_scale, "dlm_refine": a.dlm_refine,
                      "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
