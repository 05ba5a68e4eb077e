"""Direct harmonic TSD GAF of a wing's own modes against the DLM at chosen reduced frequencies (prints JSON).

Each column is one run: the mode oscillates alone, at a peak displacement of 0.2 % of c_ref, with a one-period
ramp, and the last period is analysed. Used in docs/transonic.md section 7.3 to tell the TSD solver from its ROM
and to check the DLM's lattice and the TSD grid at high k.

    python -m benchmarks.tsd_harmonic_check [--wing agard-445.6] [--mach 0.7] [--k 0.2 0.95] [--columns 0 2]
        [--grid-scale 1.0] [--n-z 22] [--dlm-refine 2] [--dt-star 0.1]
        [--cycles N]
"""

from __future__ import annotations

import argparse
import json
import math
from dataclasses import replace

import numpy as np

from romams_core.aero.dlm import DlmSolver
from romams_core.anchors import tone_amplitudes
from romams_core.mesh import standard_mesh
from romams_core.structure.modal import modal_analysis
from romams_core.training_tsd import make_tsd_solver
from romams_core.wing import template

#: peak surface displacement of a harmonic run, fraction of c_ref
PEAK = 0.002


def harmonic_column(solver, mesh, shapes: np.ndarray, mach: float, k: float, col: int,  # noqa: ANN001
                    dts: float = 0.1, cycles: int | None = None) -> np.ndarray:
    """First-harmonic GAC column [m] (m^3 per unit generalized displacement) of shape ``col`` at k (c_ref / 2)."""
    om = 2.0 * k
    cycles = cycles or (3 if k > 0.5 else 2)
    t = np.arange(int(round(cycles * 2 * math.pi / om / dts)) + 1) * dts
    ramp = np.minimum(1.0, t / (2 * math.pi / om))
    last = t >= t[-1] - 2 * math.pi / om
    sig = np.zeros((t.size, shapes.shape[1]))
    sig[:, col] = PEAK * mesh.c_ref / np.abs(shapes[:, col]).max() * np.sin(om * t) * ramp
    gac = solver.simulate(mesh, shapes, sig, mach, dts)
    return first_harmonic(gac[last], t[last], om) / first_harmonic(sig[last, col], t[last], om)


def first_harmonic(x: np.ndarray, t: np.ndarray, om: float) -> np.ndarray:
    """Complex amplitude c of x ~ Re(c e^{i om t}) + const by least squares over the samples (x [T] or [T, m]).

    Exact for a sinusoid on any window. The plain sum of x e^{-i om t} over a window that is not a whole number of
    samples per period leaks the e^{+i om t} half: 33.07 samples per period (k 0.95, dt* 0.1) made 5 % of magnitude.
    """
    return tone_amplitudes(x, t, np.array([om]))[0]


def main() -> None:
    """Run the harmonic columns and print the ratios to the DLM's GAF."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--wing", default="agard-445.6")
    ap.add_argument("--mach", type=float, default=0.7)
    ap.add_argument("--k", type=float, nargs="+", default=[0.2, 0.95])
    ap.add_argument("--columns", type=int, nargs="+", default=[0, 2])
    ap.add_argument("--grid-scale", type=float, default=1.0)
    ap.add_argument("--n-z", type=int, default=None, help="cells on each side of the mean plane (default: the grid's)")
    ap.add_argument("--dlm-refine", type=int, default=2)
    ap.add_argument("--dt-star", type=float, default=0.1, help="signal step (t*); the solver subdivides it")
    ap.add_argument("--cycles", type=int, default=None, help="cycles per run (default 3 above k 0.5, else 2)")
    a = ap.parse_args()
    wing = template(a.wing)
    mesh = standard_mesh(wing.planform)
    shapes = modal_analysis(wing, None, 4, mesh).shapes
    solver = make_tsd_solver(grid_scale=a.grid_scale)  # flat: the linear limit
    if a.n_z is not None:
        solver.grid = replace(solver.grid, n_z=a.n_z)
    rows = []
    for k in a.k:
        dlm = DlmSolver(refine=a.dlm_refine).gaf(mesh, shapes, a.mach, np.array([k]))[0]
        for col in a.columns:
            h = harmonic_column(solver, mesh, shapes, a.mach, k, col, a.dt_star, a.cycles)
            ratio = h[col] / dlm[col, col]
            rows.append({"k": k, "column": col, "magnitude_ratio": float(abs(ratio)),
                         "phase_deg": float(np.degrees(np.angle(ratio)))})
    print(json.dumps({"wing": a.wing, "mach": a.mach, "grid_scale": a.grid_scale, "n_z": solver.grid.n_z,
                      "dlm_refine": a.dlm_refine, "dt_star": a.dt_star, "cycles": a.cycles,
                      "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
