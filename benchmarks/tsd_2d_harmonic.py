"""2-D flat plate oscillating in plunge or pitch: first-harmonic TSD lift against compressible linear theory (JSON).

The linear limit of the TSD at high reduced frequency, without the 3-D wing, the ROM or the standard mesh. The plate
starts from rest, the motion is ramped in over two cycles (half-cosine), and the first harmonic of the lift is taken
over the last cycles. The 2-D grid reaches 40 chords so that no far-field reflection returns within the analysed
window. The reference is the doublet-lattice root strip of a rectangular AR 40 wing (``dlm_strip``), the recipe that
tests/test_dlm.py checks against Theodorsen at M = 0. docs/transonic.md section 7.3 has the numbers.

    python -m benchmarks.tsd_2d_harmonic [--mach 0.5 0.7] [--k 0.1 0.5 1.0] [--modes plunge pitch]
"""

from __future__ import annotations

import argparse
import json
import math
import time
from typing import Any

import numpy as np

from romams_core.aero.tsd.coefficients import tsd_coefficients
from romams_core.aero.tsd.flow import TsdFlow
from romams_core.aero.tsd.grid import GridSpec, airfoil_grid
from romams_core.aero.tsd.solver import sub_iterations

#: 2-D grid of the harmonic runs: 50 uniform chord cells, boundaries at 40 chords (no reflection within 6 cycles)
HARMONIC_SPEC = GridSpec(n_chord=50, cluster=0.0, n_upstream=48, n_downstream=48, x_upstream=40.0,
                         x_downstream=40.0, n_z=60, dz0=0.02, z_max=40.0)
MODES = ("plunge", "pitch")


def _check_mode(mode: str) -> None:
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")


def harmonic_section(mach: float, k: float, mode: str, spec: GridSpec = HARMONIC_SPEC, dt: float = 0.02,
                     cycles: int = 6, last: int = 2, amp: float = 1e-3, x_pivot: float = 0.25,
                     n_sub: int | None = None) -> complex:
    """Complex first-harmonic CL of a 2-D flat plate per unit plunge h/c (up) or pitch (rad, nose up, about x_pivot).

    k is on the semichord (omega* = 2 k per t*); the internal step is the largest below ``dt`` that divides a period.
    """
    _check_mode(mode)
    g = airfoil_grid(spec)
    flow = TsdFlow(g, tsd_coefficients(mach, "ames"))
    n_sub = sub_iterations(mach) if n_sub is None else n_sub
    om = 2.0 * k
    period = 2.0 * math.pi / om
    n_per = int(math.ceil(period / dt))
    dt = period / n_per
    t_ramp = 2.0 * period
    t = dt * np.arange(1, cycles * n_per + 1)
    ramp = np.where(t < t_ramp, 0.5 * (1.0 - np.cos(math.pi * t / t_ramp)), 1.0)
    ramp_dot = np.where(t < t_ramp, 0.5 * math.pi / t_ramp * np.sin(math.pi * t / t_ramp), 0.0)
    q = amp * np.sin(om * t) * ramp
    q_dot = amp * (om * np.cos(om * t) * ramp + np.sin(om * t) * ramp_dot)
    wing = g.wing
    cl = np.empty(t.size)
    flow.start_unsteady()
    for n in range(t.size):  # time steps (the grid work is in the compiled kernels)
        w = np.full(g.xc.size, q_dot[n]) if mode == "plunge" else -q[n] - q_dot[n] * (g.xc - x_pivot)
        flow.w_up[...] = np.where(wing, w[:, None], 0.0)
        flow.w_lo[...] = flow.w_up
        flow.step(dt, n_sub)
        cl[n] = float(flow.cell_lift(dt)[:, 0].sum())
    tail = slice(t.size - last * n_per, t.size)
    e = np.exp(-1j * om * t[tail])
    return complex((cl[tail] * e).sum() / (amp * np.sin(om * t[tail]) * e).sum())


def dlm_strip(mach: float, k: float, mode: str, x_pivot: float = 0.25, n_chord: int = 24,
              n_span: int = 32) -> complex:
    """Complex CL per unit plunge h/c or pitch (rad) from the DLM root strip of a rectangular AR 40 wing.

    Span stations eta^2 (fine at the root); the same convention as ``harmonic_section``.
    """
    from romams_core.aero import dlm
    from romams_core.mesh import Planform, StandardMesh, standard_mesh

    _check_mode(mode)
    pf = Planform(root_chord=1.0, tip_chord=1.0, semispan=20.0, n_chord=n_chord, n_span=n_span)
    xi, eta = np.meshgrid(np.linspace(0.0, 1.0, n_chord + 1), np.linspace(0.0, 1.0, n_span + 1) ** 2.0)
    px, py = pf.to_xy(xi.ravel(), eta.ravel())
    mesh = StandardMesh(planform=pf, x=px, y=py, panels=standard_mesh(pf).panels)
    system = dlm.build_dlm(mesh, mach)
    shape = np.ones_like(mesh.x) if mode == "plunge" else -(mesh.x - x_pivot)
    cp = system.pressures(shape[:, None], np.array([k]))
    root = np.arange(n_chord)
    dy = mesh.y[n_chord + 1] - mesh.y[0]
    return complex((cp[0, root, 0] * system.area[root] / dy).sum())


def compare(mach: float, k: float, mode: str, **kw: Any) -> dict[str, Any]:
    """TSD and DLM-strip CL of one case, and their ratio (magnitude, phase in degrees)."""
    t0 = time.perf_counter()
    tsd = harmonic_section(mach, k, mode, **kw)
    seconds = time.perf_counter() - t0
    ref = dlm_strip(mach, k, mode)
    r = tsd / ref
    return {"mach": mach, "k": k, "mode": mode,
            "tsd": [abs(tsd), math.degrees(np.angle(tsd))], "dlm_strip": [abs(ref), math.degrees(np.angle(ref))],
            "magnitude_ratio": abs(r), "phase_deg": math.degrees(np.angle(r)), "tsd_seconds": round(seconds, 1)}


def main() -> None:
    """Print the TSD / DLM-strip table as JSON."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mach", type=float, nargs="+", default=[0.5, 0.7])
    ap.add_argument("--k", type=float, nargs="+", default=[0.1, 0.5, 1.0])
    ap.add_argument("--modes", nargs="+", default=list(MODES), choices=MODES)
    a = ap.parse_args()
    rows = []
    for mach in a.mach:
        for k in a.k:
            for mode in a.modes:
                # low k: a longer period, so a coarser step and fewer cycles give the same window
                kw: dict[str, Any] = {"dt": 0.04, "cycles": 4} if k < 0.3 else {}
                rows.append(compare(mach, k, mode, **kw))
                print(json.dumps(rows[-1]), flush=True)
    print(json.dumps({"grid": HARMONIC_SPEC.__dict__, "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
