"""Quasi-steady TSD GAF of a wing's own modes against the DLM extrapolated to zero box size (prints JSON).

The low-k end of the linear-limit comparison (docs/transonic.md 7.3). Each TSD column is one run: the mode is
ramped to a peak displacement of 0.2 % of c_ref (smooth step over 5 t*) and held; the GAC at the end of the
hold is the steady column. The DLM is run at k 0.001 on lattices refined 2, 3 and 4 times; its error falls as
the box size (first order), so the zero-box value is 4 D_4 - 3 D_3 (Richardson), and D_2 / D_3 / D_4 show the
order. The columns are marched side by side (``simulate_records``).

    python -m benchmarks.tsd_steady_check [--wing agard-445.6] [--mach 0.7] [--columns 0 1 2 3]
        [--hold 40] [--grid-scale F] [--n-chord N] [--n-span N] [--grid KEY=VALUE ...] [--dlm-refine 2 3 4]
        [--far-field plain] [--shapes analytic]

``--shapes analytic`` replaces the wing's modes by smooth polynomial shapes (pitch about the root mid-chord,
parabolic bending, linear twist, parabolic chordwise camber, all in c_ref units). Both solvers see the same
bilinear interpolant of them on the standard mesh (almost exact for the first three), so a difference that stays is the
aerodynamics', not the shapes' interpolation. The bending shape has no streamwise slope, so its steady diagonal
entry is zero: compare columns 0, 2 and 3 (``--columns 0 2 3``).

``--grid`` sets any other field of the TSD grid (``romams_core.aero.tsd.grid.GridSpec``), e.g.
``--grid n_z=33 dz0=0.0133`` (normal direction) or ``--grid z_max=16 n_z=26`` (far field).
"""

from __future__ import annotations

import argparse
import json
from dataclasses import replace

import numpy as np

from romams_core.aero.dlm import DlmSolver, zero_box
from romams_core.aero.tsd.flow import FAR_FIELDS, TsdFlow
from romams_core.errors import InputError
from romams_core.mesh import standard_mesh
from romams_core.structure.modal import modal_analysis
from romams_core.training_tsd import make_tsd_solver
from romams_core.wing import template


def steady_columns(solver, mesh, shapes: np.ndarray, mach: float, cols: list[int],  # noqa: ANN001
                   hold: float = 40.0, dts: float = 0.1) -> tuple[np.ndarray, float]:
    """Steady GAC diagonal entries [len(cols)] (m^3 per unit generalized displacement) and the last-quarter drift."""
    t = np.arange(int(round((5.0 + hold) / dts)) + 1) * dts
    s = np.clip(t / 5.0, 0.0, 1.0)
    ramp = s * s * (3.0 - 2.0 * s)
    amps = [0.002 * mesh.c_ref / np.abs(shapes[:, c]).max() for c in cols]
    records = []
    for c, a in zip(cols, amps, strict=True):
        sig = np.zeros((t.size, shapes.shape[1]))
        sig[:, c] = a * ramp
        records.append(sig)
    gacs = solver.simulate_records(mesh, shapes, records, mach, dts)
    mid = int(round((5.0 + 0.75 * hold) / dts))
    diag = np.array([g[-1, c] / a for g, c, a in zip(gacs, cols, amps, strict=True)])
    drift = max(abs(g[-1, c] / g[mid, c] - 1.0) for g, c in zip(gacs, cols, strict=True))
    return diag, float(drift)


def analytic_shapes(mesh) -> np.ndarray:  # noqa: ANN001
    """Pitch (x - x_mid) / c_ref, bending (y / b)^2, twist (x - x_mid) y / (b c_ref) and camber
    ((x - x_mid) / c_ref)^2 at the mesh nodes [N, 4]."""
    x_mid = mesh.planform.root_chord / 2.0
    c, b = mesh.c_ref, mesh.planform.semispan
    return np.column_stack([(mesh.x - x_mid) / c, (mesh.y / b) ** 2, (mesh.x - x_mid) * mesh.y / (b * c),
                            ((mesh.x - x_mid) / c) ** 2])


def dlm_sequence(mesh, shapes: np.ndarray, mach: float, refines: list[int]) -> dict[int, np.ndarray]:  # noqa: ANN001
    """Real part of the DLM's diagonal GAC at k 0.001 (m^3) per lattice refinement."""
    return {r: DlmSolver(refine=r).gaf(mesh, shapes, mach, np.array([0.001]))[0].diagonal().real
            for r in refines}


def grid_overrides(ap: argparse.ArgumentParser, grid: object, items: list[str]) -> dict[str, float | int]:
    """``KEY=VALUE`` items as GridSpec field values, typed like the field (usage error on an unknown key)."""
    out: dict[str, float | int] = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not hasattr(grid, key):
            ap.error(f"--grid {item!r}: expected KEY=VALUE with KEY a GridSpec field")
        kind = type(getattr(grid, key))
        try:
            out[key] = kind(value)
        except ValueError:
            ap.error(f"--grid {item!r}: {key} needs a {kind.__name__}")
    return out


def main() -> None:
    """Run the steady columns and print the ratios to the DLM on each lattice and extrapolated."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--wing", default="agard-445.6")
    ap.add_argument("--mach", type=float, default=0.7)
    ap.add_argument("--columns", type=int, nargs="+", default=[0, 1, 2, 3])
    ap.add_argument("--hold", type=float, default=40.0, help="hold after the ramp (t*)")
    ap.add_argument("--grid-scale", type=float, default=1.0, help="every cell count x F (GridSpec.scaled)")
    ap.add_argument("--n-chord", type=int, default=None)
    ap.add_argument("--n-span", type=int, default=None)
    ap.add_argument("--grid", nargs="+", default=[], metavar="KEY=VALUE", help="other GridSpec fields")
    ap.add_argument("--dlm-refine", type=int, nargs="+", default=[2, 3, 4])
    ap.add_argument("--shapes", choices=("modes", "analytic"), default="modes",
                    help="the wing's first 4 modes, or smooth polynomial shapes (analytic_shapes)")
    ap.add_argument("--far-field", choices=FAR_FIELDS, default=TsdFlow.far_field,
                    help="the TSD's outer faces (TsdFlow.far_field)")
    a = ap.parse_args()
    wing = template(a.wing)
    mesh = standard_mesh(wing.planform)
    shapes = (analytic_shapes(mesh) if a.shapes == "analytic"
              else modal_analysis(wing, None, 4, mesh).shapes)
    solver = replace(make_tsd_solver(), far_field=a.far_field)  # flat: the linear limit
    if a.grid_scale != 1.0:
        solver.grid = solver.grid.scaled(a.grid_scale)
    mods = {k: v for k, v in (("n_chord", a.n_chord), ("n_span", a.n_span)) if v is not None}
    mods.update(grid_overrides(ap, solver.grid, a.grid))
    try:
        solver.grid = replace(solver.grid, **mods)
    except InputError as exc:  # e.g. dz0 * n_z beyond z_max
        ap.error(str(exc))
    tsd, drift = steady_columns(solver, mesh, shapes, a.mach, a.columns, a.hold)
    dlm = dlm_sequence(mesh, shapes, a.mach, a.dlm_refine)
    r_hi, r_lo = sorted(a.dlm_refine)[-1], sorted(a.dlm_refine)[-2]
    extrap = zero_box(dlm[r_lo], dlm[r_hi], r_lo, r_hi)
    cols = a.columns
    print(json.dumps({
        "wing": a.wing, "mach": a.mach, "grid_scale": a.grid_scale, "grid": mods or "default", "far_field": a.far_field,
        "shapes": a.shapes, "columns": cols, "hold": a.hold,
        "tsd_drift_last_quarter": drift, "tsd": tsd.real.tolist(),
        "dlm": {str(r): dlm[r][cols].tolist() for r in a.dlm_refine},
        "dlm_zero_box": extrap[cols].tolist(),
        "tsd_over_dlm": {str(r): (tsd.real / dlm[r][cols]).tolist() for r in a.dlm_refine},
        "tsd_over_dlm_zero_box": (tsd.real / extrap[cols]).tolist(),
    }, indent=1))


if __name__ == "__main__":
    main()
