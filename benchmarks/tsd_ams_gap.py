"""Which TSD ROM is right where one design's flutter is decided: the basis ROM (ROM-AMS) against the design's own-mode
ROM (ROM-PMS) and against direct harmonic TSD runs of the design's modes (prints JSON).

The cropped-delta basis and random designs of ``benchmarks.accuracy_rom_ams`` (25 samples, MAC 0.9999, 8 shapes,
seed 7). One process pool runs the two trainings and the harmonic columns (each mode oscillating alone at each
``--k``, ``benchmarks.tsd_harmonic_check.harmonic_column``). Reports, per k, the GAF columns of both ROMs relative to
the direct TSD ones; the two ROMs' GAF over a k grid; each ROM's free-run NRMSE on the design's modal validation
record (the basis ROM sees it through the projection), and the flutter points:
- of each ROM as trained;
- of each ROM with its GAF corrected to the direct TSD columns (``corrected_aero``: the ROM's error at the ``--k``
  points, interpolated linearly in k, held outside). With two k points bracketing the flutter k this is the TSD's
  own flutter point on the design's modes (the full-order reference the TSD has no frequency-domain solve for);
  both ROMs must land on it;
- of ARX refits on the same TSD records at other orders (``--orders``; no new TSD run): how much of the spread is
  the identification.
``--out DIR`` keeps the trained ROMs (pickle) and the transfer tables (NPZ) for follow-up fits; ``--basis-from DIR``
reuses the basis ROM kept there (same Mach and orders: it is the same training for every design). Both ROMs are
plain (``anchor_k`` None), as in docs/transonic.md 7.2: the study is of the identification's low-k scatter, which
the TSD training's default anchors (7.11) correct.

    python -m benchmarks.tsd_ams_gap [--design 2] [--mach 0.95] [--na 12] [--nb 12] [--k 0.05 0.1]
        [--orders 8 10 12 14 16] [--grid-scale 1.0] [--processes 2] [--out DIR] [--basis-from DIR]
"""

from __future__ import annotations

import argparse
import json
import pickle
import time
from multiprocessing import get_context
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.accuracy_rom_ams import eas, pct_error
from benchmarks.tsd_harmonic_check import harmonic_column
from romams.pipeline import rom_identity
from romams.services.training import train
from romams_core.arx import fit_arx, nrmse
from romams_core.basis import build_basis_for_wing, project, random_designs
from romams_core.mesh import standard_mesh
from romams_core.pk import pk_flutter
from romams_core.statespace import DiscreteSS, arx_to_ss, to_modal
from romams_core.structure.modal import modal_analysis
from romams_core.training_tsd import make_tsd_solver
from romams_core.wing import template

K_GRID = np.round(np.arange(0.01, 0.301, 0.01), 6)


def corrected_aero(ss: DiscreteSS, ks: np.ndarray, direct: np.ndarray) -> Any:
    """k [n] -> GAF [n, k, k] (m^3): the ROM's plus its error at the anchors ks (direct [na, k, k] minus the ROM's),
    linear in k between anchors and held outside them."""
    delta = direct - ss.freqresp(ks)

    def aero(k: np.ndarray) -> np.ndarray:
        k = np.atleast_1d(np.asarray(k, dtype=float))
        pos = np.interp(k, ks, np.arange(ks.size, dtype=float))
        lo = np.floor(pos).astype(int)
        hi = np.minimum(lo + 1, ks.size - 1)
        w = (pos - lo)[:, None, None]
        return ss.freqresp(k) + (1.0 - w) * delta[lo] + w * delta[hi]

    return aero


def pk_point(aero: Any, omega: np.ndarray, c_ref: float, mach: float, zeta: float) -> dict[str, Any]:
    """p-k flutter point (EAS m/s, rad/s, mode) of harmonic aerodynamics ``aero`` (callable k -> GAF)."""
    p = pk_flutter(omega, aero, c_ref, mach, zeta=zeta)
    return {"v_eas": eas(p.q_flutter_pa), "omega": p.omega_flutter_rad_s, "mode": p.flutter_mode}


def refit(rom: Any, order: int) -> DiscreteSS | None:
    """ARX of orders order/order fitted to a trained ROM's own TSD records (full realization); None if unstable."""
    ss = arx_to_ss(fit_arx(rom.signals_train, rom.gac_train, order, order, dt_star=rom.dt_star), rom.dt_star)
    return ss if ss.spectral_radius() < 1.0 else None


def _setup(design: int) -> tuple[Any, Any, Any, Any]:
    """(wing, mesh, basis, modal of the design) as in benchmarks.accuracy_rom_ams."""
    wing = template("cropped-delta")
    mesh = standard_mesh(wing.planform)
    basis = build_basis_for_wing(wing, samples=25, modes=4, mac_threshold=0.9999, max_basis=8)
    x = random_designs(wing, design + 1, seed=7)[design]
    return wing, mesh, basis, modal_analysis(wing, x, 4, mesh)


def _task(args: tuple[str, int, dict[str, Any], float, Any]) -> tuple[tuple[str, int, Any], Any, float]:
    """Worker body: ("basis"|"modes", -, ident, mach, -) trains a ROM; ("harmonic", j, ident, mach, k) runs mode j."""
    kind, col, ident, mach, k = args
    t0 = time.perf_counter()
    wing, mesh, basis, modal = _setup(ident["design"])
    ident = {key: v for key, v in ident.items() if key != "design"}
    if kind == "harmonic":
        options = {key: v for key, v in ident["options"].items() if key in ("thickness_form", "thickness_to_chord",
                                                                                "grid_scale", "coefficients")}
        out = harmonic_column(make_tsd_solver(**options), mesh, modal.shapes, mach, float(k), col)
    else:
        out = train(mesh, basis.shapes if kind == "basis" else modal.shapes, mach, ident)
    return (kind, col, k), out, time.perf_counter() - t0


def analyse(rom_b: Any, rom_p: Any | None, gamma: np.ndarray, omega: np.ndarray, c_ref: float, mach: float,
            zeta: float, ks: np.ndarray, direct: np.ndarray, orders: tuple[int, ...] = ()) -> dict[str, Any]:
    """Compare the basis ROM (through gamma [m, k]) and the own-mode ROM (optional) with the direct TSD GAF columns
    direct [nk, k, k] at ks: entry errors, flutter as trained and corrected to the direct GAF, order refits."""
    models = {"ams": to_modal(rom_b.ss, gamma)} | ({} if rom_p is None else {"pms": rom_p.ss})
    scale = float(np.abs(direct).max())
    res: dict[str, Any] = {"harmonic": [], "flutter": {}, "refits": []}
    for i, k in enumerate(ks):
        pairs = [[[float(z.real), float(z.imag)] for z in r] for r in direct[i]]
        row: dict[str, Any] = {"k": float(k), "direct": pairs}
        for name, ss in models.items():
            h = ss.freqresp(np.array([k]))[0]
            row[f"{name}_err_of_max_pct"] = float(100 * np.abs(h - direct[i]).max() / scale)
            row[f"{name}_entry_err_pct"] = (100 * np.abs(h - direct[i]) / scale).round(2).tolist()
            ratio = np.diag(h) / np.diag(direct[i])
            row[f"{name}_diag_ratio"] = [[float(abs(r)), float(np.degrees(np.angle(r)))] for r in ratio]
        res["harmonic"].append(row)
    for name, ss in models.items():
        res["flutter"][name] = pk_point(lambda k, ss=ss: ss.freqresp(np.atleast_1d(k)), omega, c_ref, mach, zeta)
        res["flutter"][f"{name}_corrected"] = pk_point(corrected_aero(ss, ks, direct), omega, c_ref, mach, zeta)
    fom = res["flutter"]["ams_corrected"]["v_eas"]  # the TSD's own flutter point (both corrected ROMs agree)
    for name in models:
        res["flutter"][f"{name}_vs_tsd_pct"] = pct_error(res["flutter"][name]["v_eas"], fom)
    if "pms" in models:
        res["flutter"]["corrected_ams_vs_pms_pct"] = pct_error(fom, res["flutter"]["pms_corrected"]["v_eas"])
    for order in orders:
        for name, rom, to in (("ams", rom_b, gamma), ("pms", rom_p, None)):
            ss = None if rom is None else refit(rom, order)
            if ss is None:
                continue
            ss_m = ss if to is None else to_modal(ss, to)
            point = pk_point(lambda k, s=ss_m: s.freqresp(np.atleast_1d(k)), omega, c_ref, mach, zeta)
            res["refits"].append({"rom": name, "order": order, **point, "vs_tsd_pct": pct_error(point["v_eas"], fom),
                                  "validation_nrmse_max_pct": float(100 * nrmse(
                                      rom.gac_validation, ss.simulate(rom.signals_validation)).max())})
    return res


def run(design: int = 2, mach: float = 0.95, na: int = 12, nb: int = 12, ks: tuple[float, ...] = (0.05, 0.1),
        orders: tuple[int, ...] = (8, 10, 12, 14, 16), grid_scale: float = 1.0, processes: int = 2,
        out: Path | None = None, basis_from: Path | None = None) -> dict[str, Any]:
    """Train both ROMs, run the harmonic columns, compare (see the module docstring); a JSON-able dict."""
    t0 = time.perf_counter()
    wing, mesh, basis, modal = _setup(design)
    options: dict[str, Any] = {"anchor_k": None}  # plain ROMs (docs/transonic.md 7.2); the default is anchored
    if grid_scale != 1.0:
        options["grid_scale"] = grid_scale
    ident = {**rom_identity("tsd", na=na, nb=nb, options=options, wing=wing), "design": design}
    n_modes = modal.shapes.shape[1]
    kept = None
    if basis_from is not None:
        with open(basis_from / "roms.pkl", "rb") as fh:
            kept = pickle.load(fh)["basis"]
        if abs(kept.mach - mach) > 1e-12 or (kept.na, kept.nb) != (na, nb):
            raise SystemExit(f"--basis-from holds a Mach {kept.mach} ROM of orders {kept.na}/{kept.nb}, not {mach} "
                             f"at {na}/{nb}")
    jobs = [] if kept is not None else [("basis", -1, ident, mach, None)]
    jobs += [("modes", -1, ident, mach, None)]
    jobs += [("harmonic", j, ident, mach, k) for k in ks for j in range(n_modes)]
    with get_context("spawn").Pool(processes) as pool:
        done = {key: (val, sec) for key, val, sec in pool.imap_unordered(_task, jobs)}
    rom_b = kept if kept is not None else done[("basis", -1, None)][0]
    rom_p = done[("modes", -1, None)][0]
    gamma = project(basis.shapes, modal.shapes).gamma
    direct = np.array([np.column_stack([done[("harmonic", j, k)][0] for j in range(n_modes)]) for k in ks])
    res: dict[str, Any] = {"design": design, "mach": mach, "na": na, "nb": nb, "grid_scale": grid_scale,
                           "c_ref": mesh.c_ref, "omega": [float(w) for w in modal.omega],
                           "seconds": {f"{kind}{'' if col < 0 else col}{'' if k is None else f'@{k}'}": sec
                                       for (kind, col, k), (_, sec) in done.items()}}
    res.update(analyse(rom_b, rom_p, gamma, modal.omega, mesh.c_ref, mach, wing.modal_damping, np.asarray(ks),
                       direct, orders))
    ams = to_modal(rom_b.ss, gamma)
    ta, tp = ams.freqresp(K_GRID), rom_p.ss.freqresp(K_GRID)
    res["ams_vs_pms_of_max_pct"] = {f"{k:g}": float(100 * np.abs(a - p).max() / np.abs(p).max())
                                    for k, a, p in zip(K_GRID, ta, tp, strict=True)}
    res["nrmse_on_modal_validation_pct"] = {  # the basis ROM sees u_b = gamma u and returns gamma^T f_b
        name: [100 * float(x) for x in nrmse(rom_p.gac_validation, ss.simulate(rom_p.signals_validation))]
        for name, ss in (("pms", rom_p.ss), ("ams", ams))}
    res["nrmse_own_validation_pct"] = {"basis": [100 * float(x) for x in rom_b.validation_nrmse],
                                       "modes": [100 * float(x) for x in rom_p.validation_nrmse]}
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        with open(out / "roms.pkl", "wb") as fh:
            pickle.dump({"basis": rom_b, "modes": rom_p, "gamma": gamma, "omega": modal.omega, "ks": np.asarray(ks),
                         "direct": direct}, fh)
        np.savez(out / "transfers.npz", k=K_GRID, ams=ta, pms=tp)
    res["wall_s"] = time.perf_counter() - t0
    return res


def main() -> None:
    """CLI entry point."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--design", type=int, default=2)
    ap.add_argument("--mach", type=float, default=0.95)
    ap.add_argument("--na", type=int, default=12)
    ap.add_argument("--nb", type=int, default=12)
    ap.add_argument("--k", type=float, nargs="+", default=[0.05, 0.1], help="harmonic TSD points (bracket k_f)")
    ap.add_argument("--orders", type=int, nargs="*", default=[8, 10, 12, 14, 16], help="ARX refits on the records")
    ap.add_argument("--grid-scale", type=float, default=1.0)
    ap.add_argument("--processes", type=int, default=2)
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--basis-from", type=Path, default=None, help="reuse the basis ROM an earlier --out kept")
    a = ap.parse_args()
    print(json.dumps(run(a.design, a.mach, a.na, a.nb, tuple(a.k), tuple(a.orders), a.grid_scale, a.processes,
                         a.out, a.basis_from)))


if __name__ == "__main__":
    main()
