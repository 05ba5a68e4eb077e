"""Flutter validation of the transonic small-disturbance (TSD) ROMs; prints JSON (a documented long run).

Cases (reference data in docs/aerodynamics.md section 14):
- ``agard``: AGARD 445.6 weakened wing, its own 4 modes, NACA 65A004 section, at the experimental points
  (M 0.499, 0.678, 0.901, 0.960), matched Mach as in the tunnel (V = V_exp, density swept; the speed is the
  equivalent sqrt(2 q_f / rho_exp)): flutter speed, frequency and flutter speed index (FSI) of the TSD and the
  DLM ROMs against the wind tunnel; the transonic dip is the FSI at M 0.960 against M 0.901. The constant-density
  sweep from V = 0 is reported too (``constant_density``): it takes an ARX ROM to reduced frequencies far above
  its excitation band (k 13 at 5 m/s), where a TSD ROM can show spurious low-speed crossings;
- ``cropped``: cropped delta bare plate at M 0.87 (ISA 10 km, V = M a): flutter dynamic pressure of the TSD and
  the DLM against the experiment (2.40 psi);
- ``study``: time-step and grid studies at one AGARD point (``--study-mach``, default 0.960): the flutter speed
  with tsd_dt halved, and with the grid scaled by 0.625 and 1.25 (cell sizes halved between the two), or by 2
  (``half``: the default grid's cells and its step halved, 8 x the points; at dt 0.02 that grid diverges at
  M 0.96 within 2 t*, docs/transonic.md 7.4);
- ``linear``: the linear limit at M 0.5 and 0.7 on the flat-plate cropped delta and on the AGARD 445.6
  planform without thickness, each wing's own 4 modes: the TSD ROM's GAF frequency response against the DLM's
  GAF (not its rational fit) over k = 0.05-1 on c_ref / 2, per entry and relative to the largest entry, on
  the default lattice, on the 4x refined one and extrapolated to zero box size (4 D_4 - 3 D_3), and the flutter
  points of the TSD and DLM ROMs (constant speed V = M a at 10 km); ``--linear-wings`` and ``--linear-machs``
  pick a part of it (e.g. one wing on a refined grid with ``--grid-scale``).

``--plot DIR`` writes DIR/agard_flutter_tsd.png (FSI and frequency ratio against Mach, TSD, DLM, experiment).
One TSD training per point takes minutes (``--processes`` trains Mach numbers in parallel).

    python -m benchmarks.validate_tsd [--cases agard,cropped,study,linear] [--plot docs] [--processes 2]
        [--na NA --nb NB] [--anchor-k K ...] [--study-variants default,dt,coarse,fine,half]
        [--linear-wings cropped-delta,agard-445.6] [--linear-machs 0.5,0.7] [--grid-scale F]

``--anchor-k`` trains every TSD ROM with the option ``anchor_k`` (direct harmonic runs of each shape at those k,
docs/transonic.md 7.7): the study then compares grids and steps at the anchors without the ARX scatter.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from typing import Any

import numpy as np

from benchmarks.accuracy_rom_ams import anchor_options, anchor_value
from benchmarks.validate_dlm import AGARD_EXPERIMENT, CROPPED_DELTA
from romams.pipeline import parallel_map
from romams.services.training import rom_identity, train
from romams_core.flutter import flutter_analysis
from romams_core.mesh import standard_mesh
from romams_core.structure.modal import modal_analysis
from romams_core.wing import template

#: AGARD 445.6 reference values of the flutter speed index (root semichord, first torsion frequency)
B_R = 0.27935
OMEGA_ALPHA = 239.3
PSI = 6894.757


def fsi(v: float, rho: float, mass_ratio_ref: tuple[float, float]) -> float:
    """Flutter speed index V / (b_r omega_alpha sqrt(mu)), mu scaled from the reference (rho_ref, mu_ref)."""
    rho_ref, mu_ref = mass_ratio_ref
    mu = mu_ref * rho_ref / rho
    return v / (B_R * OMEGA_ALPHA * math.sqrt(mu))


#: experimental mass ratios (agard445 reference): Mach -> mu
AGARD_MU = {0.499: 33.465, 0.678: 68.753, 0.901: 143.920, 0.960: 225.820}


def matched_mach_values(q_flutter_pa: float | None, mach: float) -> dict[str, float | None]:
    """Equivalent flutter speed sqrt(2 q_f / rho_exp) (m/s), its FSI and its error against the experiment (%) of a
    matched-Mach flutter dynamic pressure (Pa) at the AGARD point ``mach`` (all None without flutter)."""
    if q_flutter_pa is None:
        return {"v_f": None, "fsi": None, "v_error_pct": None}
    rho, v_exp, _ = AGARD_EXPERIMENT[mach]
    v = math.sqrt(2.0 * q_flutter_pa / rho)
    return {"v_f": v, "fsi": fsi(v, rho, (rho, AGARD_MU[mach])), "v_error_pct": 100.0 * (v / v_exp - 1.0)}


def _guarded(fn: Any) -> Any:
    """Run a point function; a TrainingError becomes a row with its message (the other points still run)."""
    from functools import wraps

    from romams_core.training import TrainingError

    @wraps(fn)
    def run(args: tuple[Any, ...]) -> dict[str, Any]:
        try:
            return fn(args)
        except TrainingError as exc:
            return {"args": list(args), "error": str(exc)}

    return run


def _identity(solver: str, options: dict[str, Any], wing: Any) -> dict[str, Any]:
    """The ROM identity of a job: ``options`` may carry the ARX orders as "na"/"nb" (None: the solver's default)."""
    opts = dict(options)
    na, nb = opts.pop("na", None), opts.pop("nb", None)
    return rom_identity(solver, na, nb, options=opts, wing=wing)


@_guarded
def _agard_point(args: tuple[float, str, dict[str, Any]]) -> dict[str, Any]:
    """Train one ROM on the AGARD wing's own modes and find its flutter point at the experimental density."""
    mach, solver, options = args
    wing = template("agard-445.6")
    mesh = standard_mesh(wing.planform)
    modal = modal_analysis(wing, None, 4, mesh)
    rho, v_exp, w_exp = AGARD_EXPERIMENT[mach]
    t0 = time.perf_counter()
    rom = train(mesh, modal.shapes, mach, _identity(solver, options, wing))
    seconds = time.perf_counter() - t0
    # matched Mach, as in the tunnel: V = V_exp fixed, the density swept; the flutter dynamic pressure at the
    # experimental density gives the equivalent speed sqrt(2 q_f / rho_exp) and the FSI
    r = flutter_analysis(modal.omega, rom.ss, rom.c_ref, mach, sweep="constant-speed", rho_ref=rho,
                         a_ref=v_exp / mach)
    matched = matched_mach_values(r.q_flutter_pa, mach)
    v = matched["v_f"]
    # constant density at the experimental density, V swept from 0 (the DLM's table in aerodynamics.md 13.2)
    rd = flutter_analysis(modal.omega, rom.ss, rom.c_ref, mach, sweep="constant-density", rho_ref=rho,
                          a_ref=v_exp / mach, v_max=2.0 * v_exp, k_band=getattr(rom, "k_max", None))
    row: dict[str, Any] = {
        "case": "agard-445.6", "mach": mach, "solver": solver, "options": options, "rho": rho, "v_f": v,
        "rho_f": r.rho_flutter, "k_f": r.k_flutter,
        "omega_f": r.omega_flutter_rad_s, "mode": r.flutter_mode, "v_exp": v_exp, "omega_exp": w_exp,
        "fsi": matched["fsi"], "fsi_exp": fsi(v_exp, rho, (rho, AGARD_MU[mach])),
        "v_error_pct": matched["v_error_pct"],
        "constant_density": {"v_f": rd.v_flutter_m_s, "omega_f": rd.omega_flutter_rad_s, "k_f": rd.k_flutter,
                             "mode": rd.flutter_mode, "outside_band": rd.outside_band},
        "train_seconds": seconds, "warnings": list(rom.warnings),
    }
    if getattr(rom, "mean_flow", None):
        mf = rom.mean_flow
        row.update(mean_flow_converged=mf["steady_converged"], mean_flow_steps=mf["steady_steps"],
                   cp_min=float(min(np.min(mf["cp_upper"]), np.min(mf["cp_lower"]))),  # as MeanFlow.cp_min
                   cp_star=mf["cp_star"],
                   validation_nrmse_max=float(max(rom.validation_nrmse)))
    return row


@_guarded
def _cropped_point(args: tuple[float, str, dict[str, Any]]) -> dict[str, Any]:
    """Cropped delta bare plate at ISA 10 km, V = M a: flutter dynamic pressure of one solver's own-mode ROM."""
    mach, solver, options = args
    wing = template("cropped-delta")
    mesh = standard_mesh(wing.planform)
    modal = modal_analysis(wing, None, 4, mesh)
    t0 = time.perf_counter()
    rom = train(mesh, modal.shapes, mach, _identity(solver, options, wing))
    seconds = time.perf_counter() - t0
    r = flutter_analysis(modal.omega, rom.ss, rom.c_ref, mach, zeta=wing.modal_damping)  # as validate_dlm
    q = r.q_flutter_pa
    return {"case": "cropped-delta", "mach": mach, "solver": solver, "q_f_pa": q, "q_f_psi": None if q is None
            else q / PSI, "omega_f": r.omega_flutter_rad_s, "mode": r.flutter_mode,
            "q_exp_pa": CROPPED_DELTA["experiment_q_pa_m087"], "train_seconds": seconds}


#: reduced frequencies (on c_ref / 2) of the linear-limit GAF comparison
LINEAR_K = np.linspace(0.05, 1.0, 20)
#: entries below this share of the largest |GAF| entry at a frequency are reported apart ("small")
SMALL_ENTRY = 0.1


def gaf_agreement(h: np.ndarray, ref: np.ndarray) -> dict[str, Any]:
    """Agreement of GAF tables h and ref [nk, m, m]: per-entry magnitude (%) and phase (deg) errors, split into
    entries >= SMALL_ENTRY of the largest |ref| at that k and smaller ones, the error relative to the largest
    entry, max_ij |h - ref| / max_ij |ref| (%), per k, and where the worst large entry's magnitude error sits
    (k index, row, column)."""
    big = np.abs(ref) >= SMALL_ENTRY * np.abs(ref).max(axis=(1, 2), keepdims=True)
    mag = 100.0 * (np.abs(h) / np.abs(ref) - 1.0)
    ph = np.degrees(np.angle(h / ref))
    rel = 100.0 * np.abs(h - ref).max(axis=(1, 2)) / np.abs(ref).max(axis=(1, 2))

    def worst(sel: np.ndarray) -> dict[str, float | None]:
        if not sel.any():
            return {"magnitude_pct": None, "phase_deg": None}
        return {"magnitude_pct": float(np.abs(mag[sel]).max()), "phase_deg": float(np.abs(ph[sel]).max())}

    at = np.unravel_index(int(np.argmax(np.where(big, np.abs(mag), -1.0))), mag.shape)
    return {"large_entries": worst(big), "small_entries": worst(~big), "max_error_of_largest_pct": float(rel.max()),
            "worst_large_entry_at": [int(v) for v in at],
            "diagonal": worst(np.broadcast_to(np.eye(h.shape[1], dtype=bool), h.shape)),
            "magnitude_pct": mag.round(2).tolist(), "phase_deg": ph.round(2).tolist()}


@_guarded
def _linear_point(args: tuple[str, float, dict[str, Any]]) -> dict[str, Any]:
    """Linear limit on one wing (no thickness) at one Mach: TSD ROM GAF against the DLM's, and flutter of both."""
    from romams_core.aero.dlm import DlmSolver, zero_box

    name, mach, options = args
    wing = template(name)
    mesh = standard_mesh(wing.planform)
    modal = modal_analysis(wing, None, 4, mesh)
    flat = {"thickness_form": None, "thickness_to_chord": 0.0, **options}
    t0 = time.perf_counter()
    tsd = train(mesh, modal.shapes, mach, _identity("tsd", flat, wing))
    seconds = time.perf_counter() - t0
    dlm = train(mesh, modal.shapes, mach, rom_identity("dlm", wing=wing))
    ref = DlmSolver().gaf(mesh, modal.shapes, mach, LINEAR_K)
    # the DLM converges to first order in the box size (docs/transonic.md 7.3): refine 3 and 4 extrapolated
    d3, d4 = (DlmSolver(refine=r).gaf(mesh, modal.shapes, mach, LINEAR_K) for r in (3, 4))
    h = tsd.ss.freqresp(LINEAR_K)
    row: dict[str, Any] = {"case": name, "mach": mach, "k": LINEAR_K.tolist(), "train_seconds": seconds,
                           "validation_nrmse_max": float(max(tsd.validation_nrmse)),
                           "gaf_tsd_vs_dlm": gaf_agreement(h, ref),
                           "gaf_tsd_vs_dlm_refine4": gaf_agreement(h, d4),
                           "gaf_tsd_vs_dlm_zero_box": gaf_agreement(h, zero_box(d3, d4, 3, 4)),
                           "gaf_dlm_rom_vs_dlm": gaf_agreement(dlm.ss.freqresp(LINEAR_K), ref)}
    for solver, rom in (("tsd", tsd), ("dlm", dlm)):
        r = flutter_analysis(modal.omega, rom.ss, rom.c_ref, mach, zeta=wing.modal_damping)
        row[f"q_f_{solver}"], row[f"omega_f_{solver}"] = r.q_flutter_pa, r.omega_flutter_rad_s
    if row["q_f_tsd"] and row["q_f_dlm"]:
        row["v_f_error_pct"] = 100.0 * (math.sqrt(row["q_f_tsd"] / row["q_f_dlm"]) - 1.0)
        row["omega_f_error_pct"] = 100.0 * (row["omega_f_tsd"] / row["omega_f_dlm"] - 1.0)
    return row


def main() -> None:
    """Run the chosen cases and print one JSON object."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default="agard,cropped", help="comma list of agard, cropped, study, linear")
    ap.add_argument("--machs", default=",".join(str(m) for m in AGARD_EXPERIMENT), help="AGARD Mach numbers")
    ap.add_argument("--grid-scale", type=float, default=1.0)
    ap.add_argument("--study-mach", type=float, default=0.960)
    ap.add_argument("--nrmse-tol", type=float, default=None, help="TSD ARX validation tolerance (default 0.05)")
    ap.add_argument("--na", type=int, default=None, help="TSD ARX output order (default: TSD_ORDERS)")
    ap.add_argument("--nb", type=int, default=None, help="TSD ARX input order (default: TSD_ORDERS)")
    ap.add_argument("--anchor-k", type=anchor_value, nargs="+", default=None,
                    help="TSD training option anchor_k at these k ('none': plain ROMs, as measured before "
                         "2026-12-04; default: the training's default anchors)")
    ap.add_argument("--study-variants", default="default,dt,coarse,fine",
                    help="study: comma list of default, dt (tsd_dt halved), coarse (grid x 0.625), fine (x 1.25), "
                         "half (x 2 and tsd_dt 0.01: every cell size and the step halved, 8 x the points)")
    ap.add_argument("--linear-wings", default="cropped-delta,agard-445.6", help="comma list: the linear case's wings")
    ap.add_argument("--linear-machs", default="0.5,0.7", help="comma list: the linear case's Mach numbers")
    ap.add_argument("--processes", type=int, default=1)
    ap.add_argument("--plot", default=None, help="directory for agard_flutter_tsd.png")
    a = ap.parse_args()
    cases = set(a.cases.split(","))
    base = {} if a.grid_scale == 1.0 else {"grid_scale": a.grid_scale}
    if a.nrmse_tol is not None:
        base["nrmse_tol"] = a.nrmse_tol
    base.update({k: v for k, v in (("na", a.na), ("nb", a.nb)) if v is not None})
    base.update(anchor_options(a.anchor_k))
    out: dict[str, Any] = {"grid_scale": a.grid_scale}
    t0 = time.perf_counter()
    if "agard" in cases:
        machs = [float(m) for m in a.machs.split(",")]
        jobs = [(m, "tsd", base) for m in machs] + [(m, "dlm", {}) for m in machs]
        out["agard"] = parallel_map(_agard_point, jobs, a.processes)
        tsd = {r["mach"]: r for r in out["agard"] if r.get("solver") == "tsd"}
        if 0.901 in tsd and 0.960 in tsd and tsd[0.901]["fsi"] and tsd[0.960]["fsi"]:
            out["transonic_dip_pct"] = 100.0 * (1.0 - tsd[0.960]["fsi"] / tsd[0.901]["fsi"])
    if "cropped" in cases:
        out["cropped"] = parallel_map(_cropped_point, [(0.87, "tsd", base), (0.87, "dlm", {})], a.processes)
    if "study" in cases:
        m = a.study_mach
        named = {"default": base, "dt": {**base, "tsd_dt": 0.01},
                 "coarse": {**base, "grid_scale": 0.625 * a.grid_scale},
                 "fine": {**base, "grid_scale": 1.25 * a.grid_scale},
                 "half": {**base, "grid_scale": 2.0 * a.grid_scale, "tsd_dt": 0.01}}
        picked = ["default", *(v for v in a.study_variants.split(",") if v != "default")]
        if unknown := sorted(set(picked) - set(named)):
            ap.error(f"--study-variants: unknown {unknown}, choose from {sorted(named)}")
        rows = parallel_map(_agard_point, [(m, "tsd", named[v]) for v in picked], a.processes)
        ref = rows[0].get("v_f")
        for name, r in zip(picked, rows, strict=True):
            r["variant"] = name
            r["change_pct"] = None if (ref is None or r.get("v_f") is None) else 100.0 * (r["v_f"] / ref - 1.0)
        out["study"] = rows
    if "linear" in cases:
        jobs = [(w, float(m), base) for w in a.linear_wings.split(",") for m in a.linear_machs.split(",")]
        out["linear"] = parallel_map(_linear_point, jobs, a.processes)
    out["seconds"] = time.perf_counter() - t0
    if a.plot and "agard" in out:
        _plot(out["agard"], a.plot)
    print(json.dumps(out, indent=1))


def _plot(rows: list[dict[str, Any]], directory: str) -> None:
    """FSI and flutter frequency ratio against Mach: TSD, DLM and experiment."""
    from pathlib import Path

    from matplotlib.figure import Figure

    fig = Figure(figsize=(8.0, 3.4), layout="constrained")
    ax1, ax2 = fig.subplots(1, 2)
    machs = sorted(AGARD_EXPERIMENT)
    ax1.plot(machs, [fsi(AGARD_EXPERIMENT[m][1], 1.0, (1.0, AGARD_MU[m])) for m in machs], "ks-",
             label="experiment (Yates)")
    ax2.plot(machs, [AGARD_EXPERIMENT[m][2] / OMEGA_ALPHA for m in machs], "ks-", label="experiment")
    for solver, style in (("tsd", "o-"), ("dlm", "^--")):
        pts = sorted((r["mach"], r) for r in rows if r.get("solver") == solver and r.get("v_f") is not None)
        ax1.plot([m for m, _ in pts], [r["fsi"] for _, r in pts], style, label=solver.upper())
        ax2.plot([m for m, _ in pts], [r["omega_f"] / OMEGA_ALPHA for _, r in pts], style, label=solver.upper())
    ax1.set_xlabel("Mach")
    ax1.set_ylabel("flutter speed index")
    ax2.set_xlabel("Mach")
    ax2.set_ylabel("omega_f / omega_alpha")
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("AGARD 445.6 weakened: TSD and DLM ROMs against experiment", fontsize=10)
    Path(directory).mkdir(parents=True, exist_ok=True)
    fig.savefig(str(Path(directory) / "agard_flutter_tsd.png"), dpi=110)


if __name__ == "__main__":
    main()
