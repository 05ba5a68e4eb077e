"""Calibrate the cropped delta planform and plate thickness to the measured bare-plate data.

Not run by the tests. Fixes aluminium (E = 70 GPa, nu = 0.33, rho = 2700 kg/m^3) and the semispan
ratio, fits the leading-edge sweep and tip-chord ratio to the measured frequency ratios
f2/f1 = 88.2/26.7 and f3/f1 = 131.8/26.7 with a fine (converged) DKT mesh, then sizes the root
chord and the thickness from f1 = 26.7 Hz and the mass 0.24 kg (for a fixed shape, f ~ t / L^2 and
m ~ t L^2). Prints JSON with the numbers and a mesh-convergence table.

Usage: python -m benchmarks.calibrate_cropped_delta [--n-chord 24 --n-span 32]
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np
from scipy.optimize import least_squares

from romams_core.mesh import Planform
from romams_core.structure.modal import modal_analysis
from romams_core.wing import ALUMINIUM, PlateStructure, WingDefinition

F_MEAS = np.array([26.7, 88.2, 131.8])
MASS = 0.24


def frequencies(sweep_deg: float, tip_ratio: float, span_ratio: float, cr: float, t: float, nc: int, ns: int):
    """Bare-plate frequencies (Hz) and mass (kg) of a planform (root chord cr, m) and thickness t (m)."""
    pf = Planform(cr, tip_ratio * cr, span_ratio * cr, math.radians(sweep_deg), 4, 4)
    s = PlateStructure(material=ALUMINIUM, thickness=t, fe_n_chord=nc, fe_n_span=ns)
    r = modal_analysis(WingDefinition("cal", pf, s), n_modes=3)
    return r.frequencies_hz, r.mass_kg


def main() -> None:
    """Run the calibration and print JSON."""
    ap = argparse.ArgumentParser()
    ap.add_argument("--n-chord", type=int, default=24)
    ap.add_argument("--n-span", type=int, default=32)
    ap.add_argument("--span-ratio", type=float, default=0.70)
    args = ap.parse_args()
    nc, ns, sr = args.n_chord, args.n_span, args.span_ratio
    target = F_MEAS[1:] / F_MEAS[0]

    def resid(p: np.ndarray) -> np.ndarray:
        f, _ = frequencies(p[0], p[1], sr, 0.4, 1.6e-3, nc, ns)
        return f[1:] / f[0] - target

    start = np.array([44.0, 0.2])
    sol = least_squares(resid, start, x_scale=[1.0, 0.05], diff_step=1e-3)
    sweep, tip = (float(v) for v in sol.x)
    f0, m0 = frequencies(sweep, tip, sr, 0.4, 1.6e-3, nc, ns)
    t = 1.6e-3 * math.sqrt(F_MEAS[0] * MASS / (f0[0] * m0))
    cr = 0.4 * ((MASS / F_MEAS[0]) / (m0 / f0[0])) ** 0.25
    conv = []
    for k in (0.5, 1.0, 2.0):
        a, b = max(2, round(nc * k)), max(2, round(ns * k))
        f, m = frequencies(sweep, tip, sr, cr, t, a, b)
        conv.append({"fe_n_chord": a, "fe_n_span": b, "frequencies_hz": [round(float(v), 3) for v in f],
                     "mass_kg": round(m, 5)})
    te_sweep = math.degrees(math.atan((sr * cr * math.tan(math.radians(sweep)) + tip * cr - cr) / (sr * cr)))
    print(json.dumps({
        "sweep_le_deg": round(sweep, 3), "tip_ratio": round(tip, 4), "semispan_ratio": sr,
        "te_sweep_deg": round(te_sweep, 2), "root_chord_m": round(cr, 5), "thickness_m": round(t, 7),
        "ratio_residual": [float(v) for v in sol.fun], "convergence": conv,
    }, indent=1))


if __name__ == "__main__":
    main()
