"""How long must a TSD step record hold its shape? One long record against its own first part (JSON).

The anchors of a TSD training (``anchors.step_anchors``) step each basis shape once and hold it ``STEP_HOLD``
(120 t*); ``anchors.step_transfer`` takes the transfer matrix at every k from that record, exact once the response
has settled. A record started from rest is causal, so its first T t* are exactly the record a hold of T gives:
one run of ``--hold`` t* gives the transfer of every shorter hold. Reported per hold and k: the largest difference
to the longest hold, as a share (%) of the largest entry of the longest hold's transfer over k > 0.

Cropped delta, the 8-shape basis of ``benchmarks.bench_tsd``, default grid; ``--columns`` picks the shapes
stepped (side by side on two threads).

    python -m benchmarks.tsd_step_hold [--mach 0.95] [--columns 0 1] [--hold 240] [--holds 60 80 120 160]
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from romams_core.anchors import step_records, step_transfer
from romams_core.basis import build_basis_for_wing
from romams_core.mesh import standard_mesh
from romams_core.training_tsd import make_tsd_solver
from romams_core.wing import template

K = (0.0, 0.005, 0.01, 0.025, 0.05, 0.1, 0.2)
DT_STAR = 0.1


def hold_differences(outs: list[np.ndarray], recs: list[np.ndarray], cols: list[int], holds: list[float],
                     k: np.ndarray) -> dict[str, list[float]]:
    """{hold: [max |G_hold - G_longest| / max |G_longest| (%) per k]} from records [T, m] of the stepped ``cols``."""
    def transfer(hold: float) -> np.ndarray:
        n = int(round(hold / DT_STAR)) + 1
        return np.stack([step_transfer(o[:n], r[:n, c], k, DT_STAR) for o, r, c in zip(outs, recs, cols,
                                                                                          strict=True)], axis=2)
    longest = (outs[0].shape[0] - 1) * DT_STAR
    ref = transfer(longest)
    scale = float(np.abs(ref[k > 0]).max())
    return {f"{h:g}": [float(100.0 * np.abs(transfer(h)[i] - ref[i]).max() / scale) for i in range(k.size)]
            for h in holds}


def main() -> None:
    """Run the long records and print one JSON object."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--mach", type=float, default=0.95)
    ap.add_argument("--columns", type=int, nargs="+", default=[0, 1])
    ap.add_argument("--hold", type=float, default=240.0)
    ap.add_argument("--holds", type=float, nargs="+", default=[60.0, 80.0, 120.0, 160.0])
    a = ap.parse_args()
    wing = template("cropped-delta")
    mesh = standard_mesh(wing.planform)
    basis = build_basis_for_wing(wing, samples=25, modes=4, mac_threshold=0.9999, max_basis=8, seed=0)
    solver = make_tsd_solver()
    every = step_records(basis.shapes, mesh.c_ref, hold=a.hold, dt_star=DT_STAR)
    recs = [every[c] for c in a.columns]
    t0 = time.perf_counter()
    outs = solver.simulate_records(mesh, basis.shapes, recs, a.mach, DT_STAR)
    k = np.asarray(K)
    print(json.dumps({"case": "cropped-delta", "mach": a.mach, "columns": a.columns, "hold": a.hold,
                      "wall_s": round(time.perf_counter() - t0, 1), "k": list(K),
                      "max_diff_pct_of_largest": hold_differences(outs, recs, a.columns, a.holds, k)}, indent=1))


if __name__ == "__main__":
    main()
