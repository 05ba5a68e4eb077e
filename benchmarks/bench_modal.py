"""Speed of the modal analysis per design (assembly + eigensolve + mapping), printed as JSON.

Target (DESIGN.md / structure part): <= 20 ms per cropped-delta design on one core, 4 modes.
Usage: python -m benchmarks.bench_modal [--designs 40] [--wing cropped-delta]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core, before numpy loads its BLAS

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

from romams_core.mesh import standard_mesh  # noqa: E402
from romams_core.structure.modal import build_model, modal_analysis, solve_modes  # noqa: E402
from romams_core.wing import template  # noqa: E402


def run(wing_name: str = "cropped-delta", n_designs: int = 40, n_modes: int = 4, seed: int = 0) -> dict[str, Any]:
    """Median / percentile timings (ms) of modal_analysis over random designs, with a stage breakdown."""
    wing = template(wing_name)
    mesh = standard_mesh(wing.planform)
    rng = np.random.default_rng(seed)
    b = wing.bounds()
    if wing.design_variables:
        designs = list(b[:, 0] + rng.random((n_designs, b.shape[0])) * (b[:, 1] - b[:, 0]))
    else:
        designs = [None] * n_designs
    modal_analysis(wing, designs[0], n_modes=n_modes, mesh=mesh)  # warm-up (imports, caches)
    total, assemble, eig = [], [], []
    for d in designs:
        t0 = time.perf_counter()
        modal_analysis(wing, d, n_modes=n_modes, mesh=mesh)
        total.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        model = build_model(wing, d, mesh)
        t1 = time.perf_counter()
        solve_modes(model, n_modes)
        t2 = time.perf_counter()
        assemble.append(t1 - t0)
        eig.append(t2 - t1)
    ms = 1e3 * np.array(total)
    s = wing.structure_for(designs[0])
    return {
        "benchmark": "modal_analysis",
        "wing": wing_name,
        "n_designs": len(designs),
        "n_modes": n_modes,
        "fe_cells": [getattr(s, "fe_n_chord", None), getattr(s, "fe_n_span", None)],
        "n_fe_nodes": int(model.xy.shape[0]),
        "n_dof_free": int(model.free.size),
        "median_ms": round(float(np.median(ms)), 3),
        "p90_ms": round(float(np.percentile(ms, 90)), 3),
        "min_ms": round(float(ms.min()), 3),
        "assembly_and_mapping_median_ms": round(1e3 * float(np.median(assemble)), 3),
        "eigensolve_median_ms": round(1e3 * float(np.median(eig)), 3),
        "target_ms": 20.0,
        "meets_target": bool(np.median(ms) <= 20.0),
    }


def main() -> None:
    """Command-line entry: print the JSON result."""
    ap = argparse.ArgumentParser()
    ap.add_argument("--wing", default="cropped-delta")
    ap.add_argument("--designs", type=int, default=40)
    ap.add_argument("--modes", type=int, default=4)
    args = ap.parse_args()
    print(json.dumps(run(args.wing, args.designs, args.modes)))


if __name__ == "__main__":
    main()
