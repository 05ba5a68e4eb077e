"""Low-k transfer matrix of the TSD from one step record per shape, against the multi-tone anchor runs (prints JSON).

The anchors of docs/transonic.md 7.7 run each basis shape alone with tones at the anchor k: 2.25 periods of the
lowest tone per shape (141 t* at k 0.05, 202 t* at k 0.035), and the k must be chosen before the training. A
smoothed step of each shape, held until the generalized forces settle, carries the whole low-k response at once:
for a linear system started from rest, G(z) = sum dy_n z^-n / sum du_n z^-n at any z = exp(2 i k dt*), exact up to
the part of dy beyond the record's end. Here both are run on the cropped-delta basis (``benchmarks.accuracy_rom_ams``'s
basis) for ``--columns`` and compared at the tone k; the step estimate is also taken from shortened records to show
how long a step must be held.

    python -m benchmarks.tsd_step_anchor [--mach 0.95] [--columns 0 1] [--hold 240] [--k 0.05 0.1]
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from benchmarks.tsd_ams_gap import _setup
from benchmarks.tsd_harmonic_check import PEAK
from romams.services.training import section_options
from romams_core.anchors import step_records, step_transfer, tone_amplitudes, tone_records
from romams_core.training_tsd import make_tsd_solver

DT_STAR = 0.1


def main() -> None:
    """Run the step and the tone records side by side and print the comparison as JSON."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mach", type=float, default=0.95)
    ap.add_argument("--columns", type=int, nargs="+", default=[0, 1])
    ap.add_argument("--hold", type=float, default=240.0, help="length of the step records (t*)")
    ap.add_argument("--k", type=float, nargs="+", default=[0.05, 0.1], help="tone reduced frequencies (c_ref / 2)")
    a = ap.parse_args()
    wing, mesh, basis, _ = _setup(0)
    shapes, ks = basis.shapes, np.asarray(a.k, dtype=float)
    solver = make_tsd_solver(**section_options(wing))
    steps = [step_records(shapes, mesh.c_ref, a.hold, DT_STAR, PEAK)[c] for c in a.columns]
    tones_all, t_tone, last = tone_records(shapes, mesh.c_ref, ks, DT_STAR, PEAK)
    tones = [tones_all[c] for c in a.columns]
    t0 = time.perf_counter()
    outs = solver.simulate_records(mesh, shapes, steps + tones, a.mach, DT_STAR)
    wall = time.perf_counter() - t0
    om = 2.0 * ks
    rows = []
    for i, col in enumerate(a.columns):
        y_t, u_t = outs[len(steps) + i], tones[i][:, col]
        g_tone = tone_amplitudes(y_t[last], t_tone[last], om) / tone_amplitudes(u_t[last], t_tone[last], om)[:, None]
        scale = np.abs(g_tone).max()
        by_len = {}
        for frac in (1 / 3, 1 / 2, 2 / 3, 5 / 6, 1.0):
            n = int(round(frac * (steps[i].shape[0] - 1))) + 1
            g_step = step_transfer(outs[i][:n], steps[i][:n, col], ks, DT_STAR)
            by_len[f"{(n - 1) * DT_STAR:g}"] = {
                "max_diff_of_largest_pct": float(100 * np.abs(g_step - g_tone).max() / scale),
                "diag_ratio": [f"{abs(v):.5f} / {np.degrees(np.angle(v)):+.3f} deg"
                               for v in g_step[:, col] / g_tone[:, col]]}
        g0 = step_transfer(outs[i], steps[i][:, col], np.array([0.0, 0.01, 0.02, 0.035]), DT_STAR)
        y = outs[i]
        tail = np.abs(y[-1] - y[-min(101, y.shape[0])]).max() / np.abs(y[-1]).max()
        rows.append({"column": col, "tone_largest_entry": float(scale), "step_vs_tone_by_hold_tstar": by_len,
                     "step_diag_k_0_0.01_0.02_0.035": [f"{v.real:.5g}{v.imag:+.5g}j" for v in g0[:, col]],
                     "tail_dy_last_10tstar_of_final_pct": float(100 * tail)})
    print(json.dumps({"mach": a.mach, "k": a.k, "hold_tstar": a.hold, "tone_record_tstar": float(t_tone[-1]),
                      "wall_s": wall, "columns": rows}, indent=1))


if __name__ == "__main__":
    main()
