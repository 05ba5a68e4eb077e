"""Projection of one structure's modes onto the PCA basis (ms), plus the basis build and hold-out fit.

Builds the cropped-delta basis (25 LHS samples x 4 modes, MAC threshold 0.995, at most 8 shapes),
then times ``project`` of one structure's 4 modes (the per-structure work of an evaluation besides
the FE eigensolve) and ``external_modal_result`` of a JSON-style FE mode set. Prints JSON.

Usage: python -m benchmarks.bench_projection [--repeats 2000]
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from romams_core.basis import build_basis_for_wing, holdout_macs, project, random_designs, snapshot
from romams_core.mesh import standard_mesh
from romams_core.modes_io import ExternalModes, external_modal_result
from romams_core.structure.modal import modal_analysis
from romams_core.wing import template


def _time_ms(fn, repeats: int) -> tuple[float, float]:
    """Median and 95th percentile (ms) of ``repeats`` calls."""
    t = np.empty(repeats)
    for i in range(repeats):
        t0 = time.perf_counter()
        fn()
        t[i] = time.perf_counter() - t0
    return float(np.median(t) * 1e3), float(np.percentile(t, 95) * 1e3)


def main() -> None:
    """Run the benchmark and print one JSON object."""
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeats", type=int, default=2000)
    ap.add_argument("--holdout", type=int, default=20)
    args = ap.parse_args()
    wing = template("cropped-delta")
    t0 = time.perf_counter()
    basis = build_basis_for_wing(wing, samples=25, modes=4, mac_threshold=0.995, max_basis=8, seed=0)
    build_s = time.perf_counter() - t0
    designs = random_designs(wing, args.holdout, seed=12345)
    macs = holdout_macs(wing, basis.shapes, designs, n_modes=4)
    shapes = snapshot(wing, designs[0], 4)
    proj_med, proj_p95 = _time_ms(lambda: project(basis.shapes, shapes, 0.98), args.repeats)
    modal_med, _ = _time_ms(lambda: modal_analysis(wing, designs[0], n_modes=4), 20)
    res = modal_analysis(wing, designs[0], n_modes=4)
    mesh = standard_mesh(wing.planform)
    ext = ExternalModes(nodes=np.column_stack([res.fe_xy, np.zeros(res.n_fe_nodes)]), shapes=res.fe_shapes,
                        frequencies_hz=res.frequencies_hz)
    ext_med, _ = _time_ms(lambda: external_modal_result(ext, mesh), 50)
    print(json.dumps({
        "benchmark": "projection",
        "n_nodes": int(basis.shapes.shape[0]),
        "n_basis": basis.n_basis,
        "n_modes": 4,
        "projection_ms_median": round(proj_med, 4),
        "projection_ms_p95": round(proj_p95, 4),
        "modal_analysis_ms_median": round(modal_med, 2),
        "external_modes_mapping_ms_median": round(ext_med, 2),
        "basis_build_s": round(build_s, 3),
        "sample_min_mac": round(basis.min_mac, 6),
        "holdout_designs": int(args.holdout),
        "holdout_min_mac_by_mode": [round(float(x), 6) for x in macs.min(axis=0)],
        "holdout_min_mac": round(float(macs.min()), 6),
    }))


if __name__ == "__main__":
    main()
