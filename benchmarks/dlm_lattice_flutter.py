"""How the DLM's flutter points move with its lattice (prints JSON).

The product's DLM splits every standard-mesh panel 2 x 2 (``DlmSolver.refine``). Its GAF converges to first order in
the box size (docs/aerodynamics.md 10.4, docs/transonic.md 7.17), and on AGARD 445.6 the default lattice's mode-4
entry is about 11 % from the converged one. What matters for the product is where that leaves the flutter point,
and on which side. Here p-k runs on the DLM's transfer table of the wing's own 4 modes (no ROM) for each lattice
and for the tables extrapolated to zero box size (r D_r - (r - 1) D_(r - 1) from the finest two):

- AGARD 445.6 weakened at its experimental points: matched Mach, the density swept at V = V_exp, as
  ``benchmarks.agard_direct_flutter`` (the same p-k gives the DLM ROM's point of ``validate_tsd`` within 0.5 %);
- the cropped delta, bare plate, at M 0.87 (10 km, V = M a; flutter dynamic pressure, as ``validate_dlm``).

    python -m benchmarks.dlm_lattice_flutter [--refine 1 2 3 4] [--machs 0.499 0.678 0.901 0.96] [--out DIR]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.agard_direct_flutter import _wing, flutter_point
from benchmarks.validate_dlm import AGARD_EXPERIMENT, CROPPED_DELTA, PSI
from romams_core.aero.dlm import DlmSolver, zero_box
from romams_core.mesh import standard_mesh
from romams_core.pk import AeroTable, pk_flutter
from romams_core.structure.modal import modal_analysis
from romams_core.wing import template

#: the tables' reduced frequencies (on c_ref / 2): fine where both wings flutter (k 0.07-0.3), coarser above
K_TABLE = np.round(np.concatenate([np.arange(0.0, 0.5, 0.01), np.arange(0.5, 1.0 + 1e-9, 0.05)]), 9)


def dlm_table(mesh: Any, shapes: np.ndarray, mach: float, refine: int, k: np.ndarray, path: Path | None) -> np.ndarray:
    """The DLM's GAF [nk, m, m] at reduced frequencies k on the lattice refined ``refine`` times, kept in (and
    reused from) ``path`` when given."""
    if path is not None and path.exists():
        kept = np.load(path)
        if np.array_equal(kept["k"], k):
            return kept["gaf"]
    gaf = DlmSolver(refine=refine).gaf(mesh, shapes, mach, k)
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savez(path, k=k, gaf=gaf)
    return gaf


def tables(name: str, mesh: Any, shapes: np.ndarray, mach: float, refines: list[int],
           out: str | None) -> dict[str, np.ndarray]:
    """Each lattice's table by name (``r2`` ...), and ``zero_box``, extrapolated from the finest two."""
    t = {f"r{r}": dlm_table(mesh, shapes, mach, r, K_TABLE, None if out is None
                            else Path(out) / f"{name}-M{mach:g}-r{r}.npz") for r in refines}
    lo, hi = refines[-2:]
    t["zero_box"] = zero_box(t[f"r{lo}"], t[f"r{hi}"], lo, hi)
    return t


def agard_rows(machs: list[float], refines: list[int], out: str | None) -> list[dict[str, Any]]:
    """AGARD 445.6's matched-Mach flutter point per Mach and lattice, with its change from the default lattice."""
    _, mesh, modal = _wing()
    rows = []
    for mach in machs:
        pts = {name: flutter_point(t, K_TABLE, modal.omega, mesh.c_ref, mach)
               for name, t in tables("agard-445.6", mesh, modal.shapes, mach, refines, out).items()}
        base = pts[f"r{DlmSolver.refine}"]["v_f"] if f"r{DlmSolver.refine}" in pts else None
        v_exp = AGARD_EXPERIMENT[mach][1]
        rows.append({"mach": mach, "v_exp": v_exp, **{
            name: {"v_f": p["v_f"], "omega_f": p["omega_f"], "k_f": p["k_f"], "mode": p["mode"],
                   "vs_experiment_pct": None if p["v_f"] is None else 100.0 * (p["v_f"] / v_exp - 1.0),
                   "vs_default_lattice_pct": None if p["v_f"] is None or not base
                   else 100.0 * (p["v_f"] / base - 1.0)} for name, p in pts.items()}})
    return rows


def cropped_row(refines: list[int], out: str | None, mach: float = 0.87) -> dict[str, Any]:
    """The cropped delta's flutter pressure at M 0.87 (10 km, V = M a) per lattice."""
    wing = template("cropped-delta")
    mesh = standard_mesh(wing.planform)
    modal = modal_analysis(wing, None, 4, mesh)
    row: dict[str, Any] = {"mach": mach, "q_exp_psi": CROPPED_DELTA["experiment_q_pa_m087"] / PSI}
    for name, t in tables("cropped-delta", mesh, modal.shapes, mach, refines, out).items():
        p = pk_flutter(modal.omega, AeroTable(K_TABLE, t), mesh.c_ref, mach, zeta=wing.modal_damping)
        q = p.q_flutter_pa
        row[name] = {"q_f_psi": None if q is None else q / PSI, "omega_f": p.omega_flutter_rad_s,
                     "k_f": p.k_flutter, "mode": p.flutter_mode}
    base = row.get(f"r{DlmSolver.refine}", {}).get("q_f_psi")
    for name in (n for n in row if isinstance(row[n], dict)):
        q = row[name]["q_f_psi"]
        row[name]["vs_default_lattice_pct"] = None if q is None or not base else 100.0 * (q / base - 1.0)
    return row


def main() -> None:
    """CLI entry point."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--refine", type=int, nargs="+", default=[1, 2, 3, 4], help="lattices, coarse to fine")
    ap.add_argument("--machs", type=float, nargs="+", default=sorted(AGARD_EXPERIMENT),
                    choices=sorted(AGARD_EXPERIMENT), help="AGARD's experimental Mach numbers to run")
    ap.add_argument("--skip-cropped", action="store_true", help="AGARD only")
    ap.add_argument("--out", default=None, help="keep (and reuse) each table here")
    a = ap.parse_args()
    if len(a.refine) < 2 or sorted(set(a.refine)) != a.refine:
        ap.error("--refine: at least two distinct lattices, coarse to fine")
    t0 = time.perf_counter()
    res: dict[str, Any] = {"refines": a.refine, "default_refine": DlmSolver.refine,
                           "agard": agard_rows(a.machs, a.refine, a.out)}
    if not a.skip_cropped:
        res["cropped_delta"] = cropped_row(a.refine, a.out)
    res["wall_s"] = round(time.perf_counter() - t0, 1)
    print(json.dumps(res, indent=1))


if __name__ == "__main__":
    main()
