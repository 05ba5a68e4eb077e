"""Flutter validation of the doublet-lattice (DLM) and UVLM ROMs against published data; prints JSON.

Cases (reference data in the project's docs/aerodynamics.md, section 12):
- AGARD 445.6 weakened wing at the experimental points (M 0.499, 0.678, 0.901, 0.960; constant density at the
  experimental density): flutter speed and frequency of the DLM and UVLM ROMs on the wing's own 4 modes, against
  the wind-tunnel values;
- cropped delta bare plate at ISA 10 km, V = M a (M 0.79, 0.87, 0.95): flutter dynamic pressure of the DLM
  (RFA ROM and the full-order p-k), and of the UVLM, against the experiment (M 0.87) and the published linear p-k;
- Goland wing at M 0, rho = 1.02 kg/m^3: flutter speed against the 3-D reference 166 m/s.

``--plot DIR`` writes DIR/agard_flutter.png (flutter speed and frequency against Mach).

    python -m benchmarks.validate_dlm [--plot docs] [--no-uvlm]
"""

from __future__ import annotations

import argparse
import json
import time
from typing import Any

import numpy as np

from romams.services.training import rom_identity, train
from romams_core.aero.dlm import DlmSolver
from romams_core.flutter import flutter_analysis
from romams_core.mesh import standard_mesh
from romams_core.pk_reference import fom_flutter
from romams_core.structure.modal import modal_analysis
from romams_core.wing import template

#: AGARD 445.6 weakened, experiment (Yates): Mach -> (density kg/m^3, V_f m/s, omega_f rad/s)
AGARD_EXPERIMENT = {0.499: (0.4278, 172.46, 128.1), 0.678: (0.2082, 231.37, 113.0), 0.901: (0.0995, 296.69, 101.1),
                    0.960: (0.0634, 310.96, 87.9)}
CROPPED_DELTA = {"experiment_q_pa_m087": 16_547.0, "published_linear_pk_q_pa_m087": 18_960.0}
PSI = 6894.757


def _flutter(modal: Any, rom: Any, mach: float, **kw: Any) -> Any:
    """Flutter search of a structure's own-mode ROM (zero structural damping; the ROM's band counted, 9.10)."""
    return flutter_analysis(modal.omega, rom.ss, rom.c_ref, mach, k_band=rom.k_max, **kw)


def agard(solvers: list[str]) -> list[dict[str, Any]]:
    """AGARD 445.6 rows: one per (Mach, solver)."""
    wing = template("agard-445.6")
    mesh = standard_mesh(wing.planform)
    modal = modal_analysis(wing, None, 4, mesh)
    rows = []
    for mach, (rho, v_exp, w_exp) in AGARD_EXPERIMENT.items():
        for solver in solvers:
            t0 = time.perf_counter()
            rom = train(mesh, modal.shapes, mach, rom_identity(solver))
            r = _flutter(modal, rom, mach, sweep="constant-density", rho_ref=rho, a_ref=v_exp / mach,
                         v_max=2.0 * v_exp)
            rows.append({"case": "agard-445.6", "mach": mach, "solver": solver, "rho": rho,
                         "v_f": r.v_flutter_m_s, "omega_f": r.omega_flutter_rad_s, "mode": r.flutter_mode,
                         "v_exp": v_exp, "omega_exp": w_exp,
                         "v_error_pct": None if r.v_flutter_m_s is None else 100 * (r.v_flutter_m_s / v_exp - 1),
                         "omega_error_pct": None if r.omega_flutter_rad_s is None else
                         100 * (r.omega_flutter_rad_s / w_exp - 1), "seconds": time.perf_counter() - t0})
    return rows


def cropped_delta(solvers: list[str]) -> list[dict[str, Any]]:
    """Cropped delta bare plate rows: q_f at ISA 10 km, V = M a, per (Mach, solver), plus the DLM p-k."""
    wing = template("cropped-delta")
    mesh = standard_mesh(wing.planform)
    modal = modal_analysis(wing, None, 4, mesh)
    rows = []
    for mach in (0.79, 0.87, 0.95):
        for solver in solvers:
            rom = train(mesh, modal.shapes, mach, rom_identity(solver))
            r = _flutter(modal, rom, mach, zeta=wing.modal_damping)
            rows.append({"case": "cropped-delta", "mach": mach, "solver": solver, "q_f": r.q_flutter_pa,
                         "q_f_psi": None if r.q_flutter_pa is None else r.q_flutter_pa / PSI,
                         "omega_f": r.omega_flutter_rad_s, "mode": r.flutter_mode})
        pk, _ = fom_flutter(mesh, modal.omega, modal.shapes, mach, zeta=wing.modal_damping, solver=DlmSolver(),
                            dk=0.1)
        rows.append({"case": "cropped-delta", "mach": mach, "solver": "dlm p-k", "q_f": pk.q_flutter_pa,
                     "q_f_psi": None if pk.q_flutter_pa is None else pk.q_flutter_pa / PSI,
                     "omega_f": pk.omega_flutter_rad_s, "mode": pk.flutter_mode})
    return rows


def goland(solvers: list[str]) -> list[dict[str, Any]]:
    """Goland wing rows at M 0, rho = 1.02 kg/m^3."""
    wing = template("goland")
    mesh = standard_mesh(wing.planform)
    modal = modal_analysis(wing, None, 4, mesh)
    rows = []
    for solver in solvers:
        rom = train(mesh, modal.shapes, 0.0, rom_identity(solver))
        r = _flutter(modal, rom, 0.0, sweep="constant-density", rho_ref=1.02, a_ref=340.3, v_max=300.0)
        rows.append({"case": "goland", "mach": 0.0, "solver": solver, "v_f": r.v_flutter_m_s,
                     "omega_f": r.omega_flutter_rad_s, "v_ref": 166.0,
                     "v_error_pct": None if r.v_flutter_m_s is None else 100 * (r.v_flutter_m_s / 166.0 - 1)})
    return rows


def plot_agard(rows: list[dict[str, Any]], path: str) -> None:
    """Flutter speed and frequency of the AGARD wing against Mach: experiment, DLM, UVLM."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8.0, 3.4), layout="constrained")
    ax_v, ax_w = fig.subplots(1, 2)
    machs = sorted(AGARD_EXPERIMENT)
    ax_v.plot(machs, [AGARD_EXPERIMENT[m][1] for m in machs], "ko-", label="experiment (Yates)")
    ax_w.plot(machs, [AGARD_EXPERIMENT[m][2] for m in machs], "ko-", label="experiment (Yates)")
    for solver, style in (("dlm", "s-"), ("uvlm", "^--")):
        sel = [r for r in rows if r["solver"] == solver and r["v_f"] is not None]
        if sel:
            ax_v.plot([r["mach"] for r in sel], [r["v_f"] for r in sel], style, label=solver.upper())
            ax_w.plot([r["mach"] for r in sel], [r["omega_f"] for r in sel], style, label=solver.upper())
    ax_v.set_xlabel("Mach")
    ax_v.set_ylabel("flutter speed (m/s)")
    ax_w.set_xlabel("Mach")
    ax_w.set_ylabel("flutter frequency (rad/s)")
    ax_v.legend(fontsize=8)
    fig.suptitle("AGARD 445.6 weakened wing, constant density at the experimental points", fontsize=10)
    fig.savefig(path, dpi=110)


def main() -> None:
    """CLI entry point."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--plot", default=None, help="directory for agard_flutter.png")
    ap.add_argument("--no-uvlm", action="store_true")
    a = ap.parse_args()
    solvers = ["dlm"] if a.no_uvlm else ["dlm", "uvlm"]
    t0 = time.perf_counter()
    ag = agard(solvers)
    out = {"agard": ag, "cropped_delta": cropped_delta(solvers), "goland": goland(solvers),
           "cropped_delta_reference": CROPPED_DELTA, "wall_s": None}
    if a.plot:
        plot_agard(ag, f"{a.plot}/agard_flutter.png")
    out["wall_s"] = round(time.perf_counter() - t0, 1)
    print(json.dumps(out, default=lambda x: float(x) if isinstance(x, np.floating) else str(x)))


if __name__ == "__main__":
    main()
