"""ROM-AMS vs ROM-PMS flutter accuracy over random designs of the cropped delta wing (prints JSON).

For each seeded random in-bounds design: modal analysis, projection on the PCA basis (MAC per mode),
ROM-AMS flutter (the basis ROM transformed to the design's modes) and ROM-PMS flutter (a ROM trained on the
design's own modes with the same solver and settings: the paper's reference; ``--solver dlm`` (default) fits
a rational function to doublet-lattice GAFs, ``--solver uvlm`` identifies an ARX model from a UVLM march)
at every Mach number. Reports the relative flutter-speed and frequency errors, their distribution and
worst case, split by whether every mode fits with MAC >= 0.99. Flutter speeds are compared as equivalent
airspeeds sqrt(2 q_f / rho_0) (``v_*`` keys), i.e. through q_f, whatever the sweep.

With ``--fom N`` the first N designs also get the full-order reference at every Mach: p-k with the solver's
own GAF on the design's modes (``romams_core.pk_reference.fom_flutter``), and the ROM-AMS and ROM-PMS
errors against it are reported (rows: ``v_fom``, ``v_error_ams_fom_pct``, ``v_error_pms_fom_pct``; summary
``fom``).

    python -m benchmarks.accuracy_rom_ams [--designs 20] [--machs 0.79 0.83 0.87 0.91 0.95] [--fom 3]
        [--solver dlm|uvlm|tsd] [--na NA --nb NB] [--grid-scale G] [--anchor-k K ...] [--anchor-pms]
        [--processes P] [--json]

``--anchor-k`` (tsd): the basis ROMs are trained with the option ``anchor_k`` (direct runs of each basis shape,
``romams_core.anchors``; "none": plain ROMs, as every TSD table measured before 2026-12-04); the ROM-PMS ROMs too
with ``--anchor-pms``, else with the training's default anchors.
"""

from __future__ import annotations

import argparse
import json
import time
from typing import Any

import numpy as np

from romams.pipeline import PAPER_MACHS, make_solver, rom_identity
from romams_core.atmosphere import density
from romams_core.basis import build_basis_for_wing, project, random_designs
from romams_core.evaluate import evaluate_structure
from romams_core.flutter import flutter_analysis
from romams_core.mesh import standard_mesh
from romams_core.pk_reference import fom_flutter
from romams_core.structure.modal import modal_analysis
from romams_core.wing import template

RHO0 = density(0.0)


def eas(q: float | None) -> float | None:
    """Equivalent airspeed (m/s) of a flutter dynamic pressure q (Pa): the speed measure compared here (on the
    paper's constant-speed sweep the true speed is M a_ref for every structure; EAS carries q_f)."""
    return None if q is None else float(np.sqrt(2.0 * q / RHO0))


def _fom_one(args: tuple[Any, np.ndarray, np.ndarray, float, float, str, str]) -> dict[str, Any]:
    """Worker-process body: full-order p-k flutter point of one (design, Mach) (top level so it pickles)."""
    mesh, omega, shapes, mach, zeta, sweep, solver = args
    t0 = time.perf_counter()
    res, _ = fom_flutter(mesh, omega, shapes, mach, zeta=zeta, sweep=sweep, solver=make_solver(solver),
                         dk=0.1 if solver == "dlm" else 0.05)
    return {"found": res.flutter_found, "v": eas(res.q_flutter_pa), "omega": res.omega_flutter_rad_s,
            "mode": res.flutter_mode, "q": res.q_flutter_pa, "seconds": time.perf_counter() - t0}


def _worst_nrmse(rom: Any) -> float | None:
    """Largest validation NRMSE of a time-domain (ARX) ROM; None for an RFA ROM (it has a fit error instead)."""
    v = getattr(rom, "validation_nrmse", None)
    return None if v is None or np.size(v) == 0 else float(np.max(v))


def pct_error(a: float | None, ref: float | None) -> float | None:
    """100 (a / ref - 1), or None when either is missing."""
    return None if a is None or ref is None else 100.0 * (a / ref - 1.0)


def anchor_value(text: str) -> float | None:
    """argparse type of ``--anchor-k``: a reduced frequency, or "none" (a plain TSD ROM)."""
    return None if text.strip().lower() == "none" else float(text)


def anchor_options(values: list[float | None] | None) -> dict[str, Any]:
    """TSD training options of ``--anchor-k``: {} (not given: the product's default anchors), {"anchor_k": None}
    ("none": plain ROMs, as every TSD number measured before 2026-12-04), or the listed k."""
    if values is None:
        return {}
    if any(v is None for v in values):
        return {"anchor_k": None}
    return {"anchor_k": [float(v) for v in values if v is not None]}


def run(n_designs: int = 20, machs: tuple[float, ...] = PAPER_MACHS, samples: int = 25, mac_threshold: float = 0.9999,
        max_basis: int = 8, seed: int = 7, sweep: str = "constant-speed", processes: int | None = None,
        ident: dict[str, Any] | None = None, fom: int = 0, pms_ident: dict[str, Any] | None = None) -> dict[str, Any]:
    """Run the comparison (full-order p-k reference for the first ``fom`` designs; ``pms_ident``: the ROM-PMS
    ROMs' identity when it differs from the basis ROMs' ``ident``); returns a JSON-able dict."""
    t0 = time.perf_counter()
    wing = template("cropped-delta")
    mesh = standard_mesh(wing.planform)
    ident = ident or rom_identity()
    basis = build_basis_for_wing(wing, samples=samples, modes=4, mac_threshold=mac_threshold, max_basis=max_basis)
    designs = random_designs(wing, n_designs, seed=seed)
    modals = [modal_analysis(wing, x, 4, mesh) for x in designs]
    # the basis ROMs (ROM-AMS) and one ROM per (design, Mach) (ROM-PMS) in one call: a frequency-domain solver
    # factorizes its AICs once per Mach for all of them; pms_roms[i * n_mach + j] is design i at Mach j
    from romams.pipeline import parallel_map, train_shape_sets

    if pms_ident is None or pms_ident == ident:
        trained = train_shape_sets(mesh, [basis.shapes, *(m.shapes for m in modals)], machs, ident, processes)
    else:
        trained = (train_shape_sets(mesh, [basis.shapes], machs, ident, processes)
                   + train_shape_sets(mesh, [m.shapes for m in modals], machs, pms_ident, processes))
    roms = dict(zip(machs, trained[0], strict=True))
    pms_roms = [r for rs in trained[1:] for r in rs]
    n_fom = min(max(int(fom), 0), n_designs)
    fom_jobs = [(mesh, m.omega, m.shapes, mach, wing.modal_damping, sweep, ident["solver"]) for m in modals[:n_fom]
                for mach in machs]
    foms = parallel_map(_fom_one, fom_jobs, processes) if fom_jobs else []
    rows = []
    for i, modal in enumerate(modals):
        ev = evaluate_structure(modal, basis.shapes, roms, sweep=sweep, zeta=wing.modal_damping)
        mac = project(basis.shapes, modal.shapes).mac
        for j, (mach, ams) in enumerate(zip(machs, ev.flutter, strict=True)):
            rom = pms_roms[i * len(machs) + j]
            pms = flutter_analysis(modal.omega, rom.ss, rom.c_ref, mach, sweep=sweep, zeta=wing.modal_damping)
            both = ams.flutter_found and pms.flutter_found
            rows.append({
                "design": i, "mach": mach, "min_mac": float(np.min(mac)),
                "v_ams": eas(ams.q_flutter_pa), "v_pms": eas(pms.q_flutter_pa),
                "omega_ams": ams.omega_flutter_rad_s, "omega_pms": pms.omega_flutter_rad_s,
                "mode_ams": ams.flutter_mode, "mode_pms": pms.flutter_mode,
                "found_ams": ams.flutter_found, "found_pms": pms.flutter_found,
                "nrmse_ams": _worst_nrmse(roms[mach]), "nrmse_pms": _worst_nrmse(rom),
                "v_error_pct": pct_error(eas(ams.q_flutter_pa), eas(pms.q_flutter_pa)) if both else None,
                "omega_error_pct": 100.0 * (ams.omega_flutter_rad_s / pms.omega_flutter_rad_s - 1.0) if both else None,
            })
            if i < n_fom:
                f = foms[i * len(machs) + j]
                rows[-1].update({
                    "v_fom": f["v"], "omega_fom": f["omega"], "mode_fom": f["mode"], "found_fom": f["found"],
                    "fom_seconds": f["seconds"],
                    "v_error_ams_fom_pct": pct_error(eas(ams.q_flutter_pa), f["v"]),
                    "v_error_pms_fom_pct": pct_error(eas(pms.q_flutter_pa), f["v"]),
                    "omega_error_ams_fom_pct": pct_error(ams.omega_flutter_rad_s, f["omega"]),
                    "omega_error_pms_fom_pct": pct_error(pms.omega_flutter_rad_s, f["omega"]),
                })

    def stats(sel: list[dict[str, Any]]) -> dict[str, Any]:
        e = np.array([abs(r["v_error_pct"]) for r in sel if r["v_error_pct"] is not None])
        w = np.array([abs(r["omega_error_pct"]) for r in sel if r["omega_error_pct"] is not None])
        mismatch = sum(r["found_ams"] != r["found_pms"] for r in sel)
        if e.size == 0:
            return {"n": len(sel), "found_mismatch": mismatch}
        return {"n": len(sel), "n_compared": int(e.size), "found_mismatch": int(mismatch),
                "v_abs_error_pct": {"max": float(e.max()), "p95": float(np.percentile(e, 95)),
                                    "median": float(np.median(e)), "mean": float(e.mean())},
                "omega_abs_error_pct_max": float(w.max()), "within_1pct": float(np.mean(e <= 1.0))}

    def fom_stats(sel: list[dict[str, Any]]) -> dict[str, Any]:
        out: dict[str, Any] = {
            "n": len(sel),
            "found_mismatch_ams": int(sum(r["found_ams"] != r["found_fom"] for r in sel)),
            "found_mismatch_pms": int(sum(r["found_pms"] != r["found_fom"] for r in sel)),
        }
        for key in ("v_error_ams_fom_pct", "v_error_pms_fom_pct", "omega_error_ams_fom_pct", "omega_error_pms_fom_pct"):
            e = np.array([abs(r[key]) for r in sel if r[key] is not None])
            if e.size:
                out[key.replace("_pct", "_abs_pct")] = {"max": float(e.max()), "median": float(np.median(e))}
        if sel:
            out["seconds_per_mach_median"] = float(np.median([r["fom_seconds"] for r in sel]))
        return out

    good = [r for r in rows if r["min_mac"] >= 0.99]
    worst = max((r for r in rows if r["v_error_pct"] is not None), key=lambda r: abs(r["v_error_pct"]), default=None)
    return {
        "designs": n_designs, "machs": list(machs), "sweep": sweep, "n_basis": int(basis.n_basis),
        "basis_min_mac": float(basis.min_mac), "solver": ident["solver"], "options": ident.get("options"),
        "pms_options": (pms_ident or ident).get("options"),
        "all": stats(rows), "mac_ge_0_99": stats(good), "worst": worst, "rows": rows,
        "fom": fom_stats([r for r in rows if "v_fom" in r]) if n_fom else None,
        "wall_s": time.perf_counter() - t0,
    }


def main() -> None:
    """CLI entry point."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--designs", type=int, default=20)
    ap.add_argument("--machs", type=float, nargs="+", default=list(PAPER_MACHS))
    ap.add_argument("--sweep", default="constant-speed")
    ap.add_argument("--fom", type=int, default=0, metavar="N",
                    help="full-order p-k reference (the solver's own GAF) for the first N designs at every Mach")
    ap.add_argument("--solver", default="dlm", choices=["dlm", "uvlm", "tsd"])
    ap.add_argument("--grid-scale", type=float, default=None, help="tsd: grid cell counts times this")
    ap.add_argument("--na", type=int, default=None, help="ARX output order (default: the solver's)")
    ap.add_argument("--nb", type=int, default=None, help="ARX input order (default: the solver's)")
    ap.add_argument("--anchor-k", type=anchor_value, nargs="+", default=None,
                    help="tsd: anchor the basis ROMs at these reduced frequencies ('none': plain ROMs; default: the "
                         "training's default anchors)")
    ap.add_argument("--anchor-pms", action="store_true", help="tsd: the ROM-PMS ROMs get --anchor-k too (else the "
                    "training's default)")
    ap.add_argument("--processes", type=int, default=None, help="training processes (default: CPU count)")
    ap.add_argument("--json", action="store_true", help="print the full JSON (default: summary only)")
    a = ap.parse_args()
    options = {"grid_scale": a.grid_scale} if a.solver == "tsd" and a.grid_scale is not None else {}
    wing = template("cropped-delta")
    pms_ident = rom_identity(a.solver, a.na, a.nb, options=options, wing=wing)
    ident = pms_ident if a.anchor_k is None else rom_identity(a.solver, a.na, a.nb, wing=wing,
                                                              options={**options, **anchor_options(a.anchor_k)})
    res = run(a.designs, tuple(a.machs), sweep=a.sweep, fom=a.fom, ident=ident, processes=a.processes,
              pms_ident=ident if a.anchor_pms else pms_ident)
    if not a.json:
        res = {k: v for k, v in res.items() if k != "rows"}
    print(json.dumps(res, indent=None if a.json else 2))


if __name__ == "__main__":
    main()
