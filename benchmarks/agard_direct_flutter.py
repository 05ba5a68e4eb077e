"""AGARD 445.6's TSD flutter point with no ROM at all, on any grid and step (prints JSON).

One step record per mode (``anchors.step_records``: the mode raised alone and held, docs/transonic.md 7.11) gives
the TSD's discrete transfer matrix of the wing's own 4 modes at every reduced frequency at once; p-k on that
table at matched Mach (V = V_exp, the density swept, the equivalent speed sqrt(2 q_f / rho_exp)) is the TSD's
flutter point with no identification in it. Run on two grids, the difference is the grid's alone: the
grid-halving study of the issue without the ARX scatter that the plain ROMs of ``validate_tsd --cases study``
carry (docs/transonic.md 7.13). The DLM's transfer matrix of the same modes gives the linear point beside it.

The 4 records march on threads about one mean flow (``TsdSolver.simulate_records``); each variant's transfer
table is kept in ``--out`` and reused, so an interrupted study resumes at the variant where it stopped.

    python -m benchmarks.agard_direct_flutter [--mach 0.96] [--grid-scale 1 2] [--dt 0.02 0.01] [--hold 120]
        [--axes xyz xyz] [--span-cluster 0.5] [--flat] [--coefficients ames] [--sweep DEG]
        [--out DIR]

``--axes`` refines one direction at a time (``x``: the chordwise and streamwise counts, ``y``: the spanwise,
``z``: the normal count and the first height), to find which resolution moves the flutter point; ``--span-cluster
0`` makes the spanwise cells uniform (finer at the root than the default's); ``--flat`` drops the thickness.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.tsd_steady_check import grid_overrides
from benchmarks.validate_dlm import AGARD_EXPERIMENT
from benchmarks.validate_tsd import matched_mach_values
from romams.services.training import section_options
from romams_core.aero.dlm import frequency_response
from romams_core.aero.tsd import TsdSolver
from romams_core.aero.tsd.coefficients import COEFFICIENT_SETS
from romams_core.aero.tsd.flow import FAR_FIELDS
from romams_core.aero.tsd.grid import GridSpec
from romams_core.anchors import STEP_HOLD, step_anchors
from romams_core.errors import InputError
from romams_core.mesh import standard_mesh
from romams_core.pk import AeroTable, pk_flutter
from romams_core.structure.modal import modal_analysis
from romams_core.wing import template

#: the p-k table's reduced frequencies (on c_ref / 2): AGARD flutters near k 0.08 at M 0.96
K_TABLE = np.round(np.arange(0.0, 1.0 + 1e-9, 0.005), 9)
#: the step record's sample (t*), as the training's
DT_STAR = 0.1


def _wing(sweep_deg: float | None = None) -> tuple[Any, Any, Any]:
    """(wing, standard mesh, its own 4 modes) of the AGARD 445.6 weakened wing (``sweep_deg``: with that
    leading-edge sweep instead of its 45 degrees at the quarter chord, the modes recomputed)."""
    wing = template("agard-445.6")
    if sweep_deg is not None:
        wing = replace(wing, planform=replace(wing.planform, sweep_le=math.radians(sweep_deg)))
    mesh = standard_mesh(wing.planform)
    return wing, mesh, modal_analysis(wing, None, 4, mesh)


@dataclass(frozen=True)
class Case:
    """What every variant of a run shares besides its grid scale, axes and step: the wing and the solver's options."""

    span_cluster: float = GridSpec.span_cluster  # 0: uniform spanwise cells
    flat: bool = False  # the planform without its thickness
    coefficients: str = "ames"
    sweep_deg: float | None = None  # leading-edge sweep instead of the wing's (its modes recomputed)
    steady_tol: float = TsdSolver.steady_tol  # the mean flow's convergence (max dphi/dt, 1/t*)
    grid: tuple[tuple[str, int | float], ...] = ()  # GridSpec fields set before the scaling: (("n_outboard", 20),)
    sponge_rate: float = TsdSolver.sponge_rate  # the absorbing layer's rate at its outer edge (1/t*)
    cross_upwind: bool = True  # False: the sweep's metric terms central everywhere (the scheme until 2026-12-05)
    far_field: str = TsdSolver.far_field  # the outer faces (TsdFlow.far_field): "wake" or "plain" (slip walls)

    def tag(self) -> str:
        """The part of a cached table's name that names this case (empty for the defaults)."""
        return (("" if self.span_cluster == GridSpec.span_cluster else f"-sc{self.span_cluster:g}")
                + ("-flat" if self.flat else "") + ("" if self.coefficients == "ames" else f"-{self.coefficients}")
                + ("" if self.sweep_deg is None else f"-sw{self.sweep_deg:g}")
                + ("" if self.steady_tol == TsdSolver.steady_tol else f"-tol{self.steady_tol:g}")
                + "".join(f"-{name}{value:g}" for name, value in self.grid)
                + ("" if self.sponge_rate == TsdSolver.sponge_rate else f"-sponge{self.sponge_rate:g}")
                + ("" if self.cross_upwind else "-central")
                + ("" if self.far_field == TsdSolver.far_field else f"-ff{self.far_field}"))

    def spec(self) -> GridSpec:
        """The unscaled grid of this case (GridSpec checks the fields: a cell count must be an int)."""
        return replace(GridSpec(span_cluster=self.span_cluster), **dict(self.grid))


def _table(wing: tuple[Any, Any, Any], mach: float, scale: float, dt: float, hold: float, out: str | None,
           axes: str = "xyz", case: Case = Case()) -> tuple[np.ndarray, float, dict[str, Any]]:
    """(transfer matrix [nk, 4, 4] of the modes' step records, seconds, mean-flow summary) of ``wing`` (``_wing``'s
    triple, of the same ``case.sweep_deg``) on one grid and step."""
    tag = f"g{scale:g}" + ("" if set(axes) == set("xyz") else axes) + case.tag()
    path = None if out is None else Path(out) / f"agard-M{mach:g}-{tag}-dt{dt:g}-h{hold:g}.npz"
    if path is not None and path.exists():
        kept = np.load(path)
        if np.array_equal(kept["k"], K_TABLE):
            return kept["gaf"], float(kept["seconds"]), json.loads(str(kept["mean_flow"]))
    definition, mesh, modal = wing
    section = {} if case.flat else section_options(definition)
    solver = TsdSolver(**section, grid=case.spec().scaled(scale, axes), dt=dt, coefficients=case.coefficients,
                       steady_tol=case.steady_tol, sponge_rate=case.sponge_rate, cross_upwind=case.cross_upwind,
                       far_field=case.far_field)
    t0 = time.perf_counter()
    gaf = step_anchors(solver, mesh, modal.shapes, mach, K_TABLE, DT_STAR, hold=hold)  # the records on threads
    seconds = time.perf_counter() - t0
    mf = solver.last_mean_flow
    summary = {} if mf is None else {"steady_steps": mf.steady.steps, "dt": mf.dt, "step_halvings": mf.step_halvings,
                                     "steady_t_star": mf.steady.steps * mf.dt,
                                     "steady_converged": mf.steady.converged, "cp_star": mf.cp_star,
                                     "cp_min": mf.cp_min}
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savez(path, k=K_TABLE, gaf=gaf, seconds=seconds, mean_flow=json.dumps(summary))
    return gaf, seconds, summary


def flutter_point(table: np.ndarray, k: np.ndarray, omega: np.ndarray, c_ref: float, mach: float) -> dict[str, Any]:
    """Matched-Mach p-k point of the transfer table [nk, 4, 4] at the experimental density of ``mach``.

    Where a branch of the density sweep leaves the table's k range (a mode's frequency doubling at a density far
    from the flutter point's, seen once on a grid x 1.5), the sweep is repeated with the table's last value held to
    k = 3 (``table_held`` True in the result); the flutter point (k near 0.08) is inside the table either way."""
    rho, v_exp, _ = AGARD_EXPERIMENT[mach]
    kw: dict[str, Any] = {"sweep": "constant-speed", "rho_ref": rho, "a_ref": v_exp / mach}
    try:
        p, held = pk_flutter(omega, AeroTable(k, table), c_ref, mach, **kw), False
    except InputError as exc:
        if exc.field != "k":
            raise
        beyond = np.linspace(k[-1], 3.0, 201)[1:]
        wide = AeroTable(np.concatenate([k, beyond]), np.concatenate([table, np.repeat(table[-1:], beyond.size, 0)]))
        p, held = pk_flutter(omega, wide, c_ref, mach, **kw), True
    return {**matched_mach_values(p.q_flutter_pa, mach), "omega_f": p.omega_flutter_rad_s, "k_f": p.k_flutter,
            "mode": p.flutter_mode, "table_held": held}


#: reduced frequencies at which each variant's transfer matrix is compared with the first variant's
TABLE_CHANGE_K = (0.0, 0.05, 0.08, 0.15, 0.3)


def table_change(ref: np.ndarray, table: np.ndarray, k: float) -> float:
    """Largest entry difference of two transfer tables [nk, 4, 4] at the K_TABLE point nearest k, % of ref's
    largest entry there."""
    i = int(np.argmin(np.abs(K_TABLE - k)))
    return float(100.0 * np.abs(table[i] - ref[i]).max() / np.abs(ref[i]).max())


def run(mach: float, scales: list[float], dts: list[float], hold: float, out: str | None,
        axes: list[str] | None = None, case: Case = Case()) -> dict[str, Any]:
    """Step records of the 4 modes on each (grid scale, dt) pair, p-k on each transfer table and on the DLM's."""
    t0 = time.perf_counter()
    wing = _wing(case.sweep_deg)
    _, mesh, modal = wing
    res: dict[str, Any] = {"mach": mach, "hold": hold, **asdict(case), "v_exp": AGARD_EXPERIMENT[mach][1],
                           "variants": []}
    tables = []
    for s, d, ax in zip(scales, dts, axes or ["xyz"] * len(scales), strict=True):
        table, seconds, mean_flow = _table(wing, mach, s, d, hold, out, ax, case)
        tables.append(table)
        res["variants"].append({"grid_scale": s, "axes": ax, "tsd_dt": d, "seconds": round(seconds, 1),
                                "mean_flow": mean_flow,
                                **flutter_point(table, K_TABLE, modal.omega, mesh.c_ref, mach)})
    first = tables[0]
    for row, table in zip(res["variants"], tables, strict=True):  # how far each table is from the first one's
        row["table_change_pct"] = {f"{kk:g}": table_change(first, table, kk) for kk in TABLE_CHANGE_K}
    ref = res["variants"][0]["v_f"]
    for row in res["variants"]:
        row["change_pct"] = None if ref is None or row["v_f"] is None else 100.0 * (row["v_f"] / ref - 1.0)
    dlm_k = K_TABLE[::2]
    res["dlm"] = flutter_point(frequency_response(mesh, modal.shapes, mach, dlm_k), dlm_k, modal.omega,
                               mesh.c_ref, mach)
    res["wall_s"] = time.perf_counter() - t0
    return res


def main() -> None:
    """CLI entry point."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--mach", type=float, default=0.960, choices=sorted(AGARD_EXPERIMENT))
    ap.add_argument("--grid-scale", type=float, nargs="+", default=[1.0, 2.0], help="grid scales, one per variant")
    ap.add_argument("--dt", type=float, nargs="+", default=[0.02, 0.01], help="tsd_dt of each variant (t*)")
    ap.add_argument("--axes", nargs="+", default=None,
                    help="the axes each variant's scale refines (any of x, y, z; default xyz: every axis)")
    ap.add_argument("--span-cluster", type=float, default=GridSpec.span_cluster,
                    help="GridSpec.span_cluster of every variant (0: uniform spanwise cells)")
    ap.add_argument("--flat", action="store_true", help="the planform without its thickness (a flat plate)")
    ap.add_argument("--coefficients", default="ames", choices=COEFFICIENT_SETS,
                    help="the TSD coefficient set (2d: no cross-flow terms G, H)")
    ap.add_argument("--sweep", type=float, default=None,
                    help="leading-edge sweep (deg) instead of the wing's; its modes recomputed (not the tunnel's wing)")
    ap.add_argument("--steady-tol", type=float, default=TsdSolver.steady_tol,
                    help="the mean flow's convergence: max dphi/dt (1/t*) at which the steady march stops")
    ap.add_argument("--grid", nargs="+", default=[], metavar="FIELD=VALUE",
                    help="GridSpec fields of every variant before its scaling, e.g. y_outboard=5 n_outboard=20")
    ap.add_argument("--sponge-rate", type=float, default=TsdSolver.sponge_rate,
                    help="damping rate (1/t*) at the outer edge of the absorbing layer (0: none)")
    ap.add_argument("--central-cross", action="store_true",
                    help="the sweep's metric terms central at supersonic points too (the scheme until 2026-12-05)")
    ap.add_argument("--far-field", choices=FAR_FIELDS, default=TsdSolver.far_field,
                    help="the outer faces: the wake's steady potential on them, or plain (slip walls in steady flow)")
    ap.add_argument("--hold", type=float, default=STEP_HOLD, help="step hold (t*)")
    ap.add_argument("--out", default=None, help="keep (and reuse) each mode's transfer column here")
    a = ap.parse_args()
    if len(a.grid_scale) != len(a.dt) or (a.axes is not None and len(a.axes) != len(a.dt)):
        ap.error("--grid-scale, --dt (and --axes) need one value each per variant")
    if a.axes is not None and any(not ax or set(ax) - set("xyz") for ax in a.axes):
        ap.error("--axes: each a combination of x, y and z")
    case = Case(a.span_cluster, a.flat, a.coefficients, a.sweep, a.steady_tol,
                tuple(grid_overrides(ap, GridSpec(), a.grid).items()), a.sponge_rate, not a.central_cross, a.far_field)
    print(json.dumps(run(a.mach, a.grid_scale, a.dt, a.hold, a.out, a.axes, case), indent=1))


if __name__ == "__main__":
    main()
