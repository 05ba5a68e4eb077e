"""ROM-AMS vs ROM-PMS flutter accuracy over random designs of the cropped delta wing (prints JSON).

For each seeded random in-bounds design: modal analysis, projection on the PCA basis (MAC per mode),
ROM-AMS flutter (the basis ROM transformed to the design's modes) and ROM-PMS flutter (an ARX model
identified on the design's own modes with the same solver, signals and orders: the paper's reference)
at every Mach number. Reports the relative flutter-speed and frequency errors, their distribution and
worst case, split by whether every mode fits with MAC >= 0.99.

    python -m benchmarks.accuracy_rom_ams [--designs 20] [--machs 0.79 0.83 0.87 0.91 0.95] [--json]
"""

from __future__ import annotations

import argparse
import json
import time
from typing import Any

import numpy as np

from romams.pipeline import PAPER_MACHS, SweepChoice, own_mode_basis, rom_identity, train_shapes  # noqa: F401
from romams_core.basis import build_basis_for_wing, project, random_designs
from romams_core.evaluate import evaluate_structure
from romams_core.flutter import flutter_analysis
from romams_core.mesh import standard_mesh
from romams_core.structure.modal import modal_analysis
from romams_core.wing import template


def run(n_designs: int = 20, machs: tuple[float, ...] = PAPER_MACHS, samples: int = 25, mac_threshold: float = 0.9999,
        max_basis: int = 8, seed: int = 7, sweep: str = "constant-speed", processes: int | None = None,
        ident: dict[str, Any] | None = None) -> dict[str, Any]:
    """Run the comparison; returns a JSON-able dict with per-design rows and statistics."""
    t0 = time.perf_counter()
    wing = template("cropped-delta")
    mesh = standard_mesh(wing.planform)
    ident = ident or rom_identity()
    basis = build_basis_for_wing(wing, samples=samples, modes=4, mac_threshold=mac_threshold, max_basis=max_basis)
    roms = dict(zip(machs, train_shapes(mesh, basis.shapes, machs, ident, processes), strict=True))
    designs = random_designs(wing, n_designs, seed=seed)
    modals = [modal_analysis(wing, x, 4, mesh) for x in designs]
    # ROM-PMS: one training per (design, Mach), spread over processes
    jobs = [(mesh, m.shapes, mach) for m in modals for mach in machs]
    from romams.pipeline import _train_one, parallel_map

    pms_roms = parallel_map(_train_one, [(a, b, c, dict(ident)) for a, b, c in jobs], processes)
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
                "v_ams": ams.v_flutter_m_s, "v_pms": pms.v_flutter_m_s,
                "omega_ams": ams.omega_flutter_rad_s, "omega_pms": pms.omega_flutter_rad_s,
                "mode_ams": ams.flutter_mode, "mode_pms": pms.flutter_mode,
                "found_ams": ams.flutter_found, "found_pms": pms.flutter_found,
                "v_error_pct": 100.0 * (ams.v_flutter_m_s / pms.v_flutter_m_s - 1.0) if both else None,
                "omega_error_pct": 100.0 * (ams.omega_flutter_rad_s / pms.omega_flutter_rad_s - 1.0) if both else None,
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

    good = [r for r in rows if r["min_mac"] >= 0.99]
    worst = max((r for r in rows if r["v_error_pct"] is not None), key=lambda r: abs(r["v_error_pct"]), default=None)
    return {
        "designs": n_designs, "machs": list(machs), "sweep": sweep, "n_basis": int(basis.n_basis),
        "basis_min_mac": float(basis.min_mac), "solver": ident["solver"],
        "all": stats(rows), "mac_ge_0_99": stats(good), "worst": worst, "rows": rows,
        "wall_s": time.perf_counter() - t0,
    }


def main() -> None:
    """CLI entry point."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--designs", type=int, default=20)
    ap.add_argument("--machs", type=float, nargs="+", default=list(PAPER_MACHS))
    ap.add_argument("--sweep", default="constant-speed")
    ap.add_argument("--json", action="store_true", help="print the full JSON (default: summary only)")
    a = ap.parse_args()
    res = run(a.designs, tuple(a.machs), sweep=a.sweep)
    if not a.json:
        res = {k: v for k, v in res.items() if k != "rows"}
    print(json.dumps(res, indent=None if a.json else 2))


if __name__ == "__main__":
    main()
