"""The linear limit without identification: the TSD's whole transfer matrix against the DLM's on refined grids
(prints JSON).

``validate_tsd --cases linear`` compares the GAF of a TSD-trained ROM with the DLM's (docs/transonic.md 7.3, 7.17):
its numbers hold the grid's error and the ARX fit's together, and every grid costs a training. Here each grid's
TSD transfer matrix of the wing's own 4 modes (flat: no thickness) comes straight from one step record per mode
(``anchors.step_anchors``, the product's anchor records), at the linear-limit comparison's reduced frequencies
(k 0.05-1 on c_ref / 2), so what changes from grid to grid is the grid's alone. Every entry, off-diagonal ones
included, is compared with the DLM on its default lattice, refined ``r`` times, and extrapolated to zero box
size (first order: r D_r - (r - 1) D_(r - 1), docs/transonic.md 7.17). With two grids or more the TSD tables
are extrapolated too (Richardson with the order ``--order``, from the finest two), which says whether the
solver's continuum limit is the DLM's entry by entry.

    python -m benchmarks.tsd_linear_direct [--wing agard-445.6] [--mach 0.7] [--grid-scale 1 1.5 2]
        [--dt 0.02 0.02 0.02] [--hold 120] [--dlm-refine 3 4] [--order 1.5] [--shapes analytic]
        [--columns 2] [--grid KEY=VALUE ...] [--out DIR]

``--out`` keeps each grid's table and reuses it, so an interrupted run resumes where it stopped. ``--columns``
runs only those shapes' motions (0-based; one record each instead of one per shape, so finer grids fit) and
reports every entry of those columns, with its ratio to each DLM reference per k. ``--grid`` sets other fields of the
default grid before each scaling (``GridSpec``, e.g. ``y_outboard=5 n_outboard=15``: the lateral face twice as
far beyond the tip, the same cells near the wing), to separate the far field's part from the cells'.
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from scipy.optimize import brentq

from benchmarks.dlm_lattice_flutter import dlm_table
from benchmarks.tsd_steady_check import analytic_shapes, grid_overrides
from benchmarks.validate_tsd import LINEAR_K, gaf_agreement
from romams_core.aero.dlm import DlmSolver, zero_box
from romams_core.aero.tsd.grid import GridSpec
from romams_core.anchors import STEP_HOLD, step_anchors
from romams_core.mesh import standard_mesh
from romams_core.structure.modal import modal_analysis
from romams_core.training_tsd import make_tsd_solver
from romams_core.wing import template

#: the step record's sample (t*), as the training's
DT_STAR = 0.1


def grid_spec(scale: float, grid: dict[str, Any] | None = None) -> GridSpec:
    """The default TSD grid with the fields ``grid`` set, then every cell count x ``scale`` (``GridSpec.scaled``)."""
    return replace(GridSpec(), **(grid or {})).scaled(scale)


def tsd_table(mesh: Any, shapes: np.ndarray, mach: float, scale: float, dt: float, hold: float,
              path: Path | None, columns: list[int] | None = None,
              grid: dict[str, Any] | None = None) -> tuple[np.ndarray, float]:
    """(TSD transfer matrix [nk, m, m] of the flat wing at LINEAR_K, in m^3 per unit displacement, or its
    ``columns`` [nk, m, len(columns)]; seconds). ``grid``: GridSpec fields of the default grid, set before the
    scaling."""
    if path is not None and path.exists():
        kept = np.load(path)
        if np.array_equal(kept["k"], LINEAR_K):
            return kept["gaf"], float(kept["seconds"])
    solver = make_tsd_solver(grid_scale=scale, tsd_dt=dt)
    solver.grid = grid_spec(scale, grid)
    t0 = time.perf_counter()
    gaf = step_anchors(solver, mesh, shapes, mach, LINEAR_K, DT_STAR, hold=hold, columns=columns)
    seconds = time.perf_counter() - t0
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savez(path, k=LINEAR_K, gaf=gaf, seconds=seconds)
    return gaf, seconds


def richardson(coarse: np.ndarray, fine: np.ndarray, ratio: float, order: float) -> np.ndarray:
    """Zero-cell-size estimate from two tables whose cell sizes differ by ``ratio`` (> 1), error ~ h^order."""
    return fine + (fine - coarse) / (ratio ** order - 1.0)


def observed_order(tables: list[np.ndarray], scales: list[float]) -> float | None:
    """Order p of the last three tables' convergence, error ~ h^p with h = 1 / scale, from the Frobenius norms of
    their two differences (None where the differences do not shrink like a power of h)."""
    if len(tables) < 3:
        return None
    h = 1.0 / np.asarray(scales[-3:], dtype=float)
    e1, e2 = (float(np.linalg.norm(b - a)) for a, b in zip(tables[-3:-1], tables[-2:], strict=True))

    def gap(p: float) -> float:
        return (h[0] ** p - h[1] ** p) / (h[1] ** p - h[2] ** p) - e1 / e2

    try:
        return float(brentq(gap, 0.05, 8.0))
    except ValueError:
        return None


def summary(h: np.ndarray, ref: np.ndarray) -> dict[str, Any]:
    """``gaf_agreement`` without its per-entry arrays: the worst errors over k of the diagonal, of the entries
    above a tenth of the largest, and relative to the largest entry; where the worst large entry's magnitude
    error sits (row, column, k)."""
    g = gaf_agreement(h, ref)
    ik, row, col = g["worst_large_entry_at"]
    return {**{key: g[key] for key in ("diagonal", "large_entries", "max_error_of_largest_pct")},
            "worst_large_entry": {"row": int(row), "col": int(col), "k": float(LINEAR_K[ik])}}


def column_summary(h: np.ndarray, ref: np.ndarray, columns: list[int]) -> dict[str, Any]:
    """Every entry (i, j) of the tables' columns h, ref [nk, m, len(columns)] (j = columns[c], 1-based in the
    keys): worst magnitude (%) and phase (deg) error over k, and |h / ref| per k."""
    ratio = np.abs(h) / np.abs(ref)
    phase = np.degrees(np.angle(h / ref))
    return {f"({i + 1},{j + 1})": {"magnitude_pct": round(float(100.0 * np.abs(ratio[:, i, c] - 1.0).max()), 2),
                                   "phase_deg": round(float(np.abs(phase[:, i, c]).max()), 2),
                                   "ratio": ratio[:, i, c].round(4).tolist()}
            for c, j in enumerate(columns) for i in range(h.shape[1])}


def run(wing_name: str, mach: float, scales: list[float], dts: list[float], hold: float, refines: list[int],
        order: float, out: str | None, shape_set: str = "modes", columns: list[int] | None = None,
        grid: dict[str, Any] | None = None) -> dict[str, Any]:
    """Every grid's TSD table (or its ``columns``) against the DLM references, and the extrapolated TSD table
    against them."""
    t0 = time.perf_counter()
    wing = template(wing_name)
    mesh = standard_mesh(wing.planform)
    shapes = analytic_shapes(mesh) if shape_set == "analytic" else modal_analysis(wing, None, 4, mesh).shapes
    tag = wing_name if shape_set == "modes" else f"{wing_name}-analytic"
    r_lo, r_hi = sorted(refines)[-2:]
    d_def, d_lo, d_hi = (dlm_table(mesh, shapes, mach, r, LINEAR_K,
                                   None if out is None else Path(out) / f"{tag}-M{mach:g}-dlm-r{r}.npz")
                         for r in (DlmSolver.refine, r_lo, r_hi))
    refs = {"dlm_default": d_def, f"dlm_refine{r_hi}": d_hi,
            "dlm_zero_box": zero_box(d_lo, d_hi, r_lo, r_hi)}
    if columns is not None:
        refs = {name: ref[:, :, columns] for name, ref in refs.items()}

    def compare(table: np.ndarray, ref: np.ndarray) -> dict[str, Any]:
        return summary(table, ref) if columns is None else column_summary(table, ref, columns)

    res: dict[str, Any] = {"wing": wing_name, "shapes": shape_set, "mach": mach, "hold": hold, "k": LINEAR_K.tolist(),
                           "dlm_refines": [r_lo, r_hi], "order": order, "columns": columns,
                           "grid": grid or "default", "grids": []}
    tables = []
    for s, d in zip(scales, dts, strict=True):
        cols = "" if columns is None else "-c" + "_".join(map(str, columns))
        cols += "".join(f"-{key}{value:g}" for key, value in sorted((grid or {}).items()))
        path = None if out is None else Path(out) / f"{tag}-M{mach:g}-g{s:g}-dt{d:g}-h{hold:g}{cols}.npz"
        table, seconds = tsd_table(mesh, shapes, mach, s, d, hold, path, columns, grid)
        tables.append(table)
        res["grids"].append({"grid_scale": s, "tsd_dt": d, "seconds": round(seconds, 1),
                             **{name: compare(table, ref) for name, ref in refs.items()}})
    res["observed_order"] = observed_order(tables, scales)
    if len(tables) >= 2:
        ratio = scales[-1] / scales[-2]
        extrap = richardson(tables[-2], tables[-1], ratio, order)
        res["extrapolated"] = {"from_scales": scales[-2:], **{name: compare(extrap, ref) for name, ref in refs.items()}}
        res["extrapolated_first_order"] = {name: compare(richardson(tables[-2], tables[-1], ratio, 1.0), ref)
                                           for name, ref in refs.items()}
    res["wall_s"] = round(time.perf_counter() - t0, 1)
    return res


def main() -> None:
    """CLI entry point."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--wing", default="agard-445.6", choices=("agard-445.6", "cropped-delta"))
    ap.add_argument("--mach", type=float, default=0.7)
    ap.add_argument("--grid-scale", type=float, nargs="+", default=[1.0, 1.5, 2.0],
                    help="every cell count x F, one per grid, coarse to fine")
    ap.add_argument("--dt", type=float, nargs="+", default=None, help="tsd_dt of each grid (t*; default 0.02)")
    ap.add_argument("--hold", type=float, default=STEP_HOLD, help="step hold (t*)")
    ap.add_argument("--dlm-refine", type=int, nargs="+", default=[3, 4])
    ap.add_argument("--order", type=float, default=1.5,
                    help="the TSD grid's order of convergence for the extrapolation (steady entries: 1.4-1.6)")
    ap.add_argument("--shapes", choices=("modes", "analytic"), default="modes",
                    help="the wing's first 4 modes, or tsd_steady_check's smooth ones (pitch, bending, twist, camber)")
    ap.add_argument("--columns", type=int, nargs="+", default=None,
                    help="run only these shapes' motions (0-based) and report every entry of their columns")
    ap.add_argument("--grid", nargs="+", default=[], metavar="KEY=VALUE",
                    help="other GridSpec fields of the default grid, set before each grid's scaling")
    ap.add_argument("--out", default=None, help="keep (and reuse) each grid's table here")
    a = ap.parse_args()
    dts = a.dt or [0.02] * len(a.grid_scale)
    if len(dts) != len(a.grid_scale):
        ap.error("--dt needs one value per --grid-scale")
    if sorted(a.grid_scale) != a.grid_scale or len(set(a.grid_scale)) != len(a.grid_scale):
        ap.error("--grid-scale: distinct values, coarse to fine")
    if a.columns is not None and not all(0 <= c < 4 for c in a.columns):
        ap.error("--columns: shape indices 0-3")
    if len(a.dlm_refine) < 2:
        ap.error("--dlm-refine: at least two lattices (the extrapolation uses the finest two)")
    grid = grid_overrides(ap, GridSpec(), a.grid)
    print(json.dumps(run(a.wing, a.mach, a.grid_scale, dts, a.hold, a.dlm_refine, a.order, a.out,
                         a.shapes, a.columns, grid), indent=1))


if __name__ == "__main__":
    main()
