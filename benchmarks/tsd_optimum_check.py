"""The TSD's own flutter point of the paper case's optimum against its ROM-AMS and ROM-PMS (prints JSON).

Table 8 of the full TSD paper case (docs/optimization.md 3a) has ROM-AMS 7 / 76 / 5 % above ROM-PMS at M 0.87 /
0.91 / 0.95. Which ROM is right is decided here by the TSD itself, at one Mach per call:
- the paper case's basis ROM and the optimum's own-mode ROM, trained with the paper case's identity and kept in
  ``--rom-dir`` (``paper_case.Trainer``: a later ``benchmarks.paper_case --rom-dir`` run reads the same files);
- direct multi-tone TSD runs of each of the optimum's modes at ``--k`` (``anchors.harmonic_anchors``, one record per
  mode, side by side), the full-order transfer matrix at those reduced frequencies (on c_ref / 2);
- ``tsd_ams_gap.analyse``: each ROM's p-k point as trained and with its GAF corrected to the direct columns. With
  anchors that bracket the flutter k, the corrected points are the TSD's own flutter point; both ROMs must land on
  it. The product's state-space search on both ROMs (the Table 8 values) is reported next to them.

Three jobs (basis ROM, own-mode ROM, direct runs) in ``--processes`` processes; 23-25 min at one Mach on 2 cores.

    python -m benchmarks.tsd_optimum_check --mach 0.91 [--k 0.035 0.05 0.07] [--x X1 .. X7] --rom-dir DIR

``--reference V_EAS`` trains (or reads) only the basis ROM, with the product's identity (default anchors since
2026-12-04), and gives its ROM-AMS flutter speed against that known TSD point (7.10: 132.38 m/s at M 0.95;
``benchmarks.tsd_direct_flutter``: 132.15 m/s), plain and with the DLM projection residual (7.12).
"""

from __future__ import annotations

import argparse
import json
import time
from multiprocessing import get_context
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks import paper_case as pc
from benchmarks.accuracy_rom_ams import anchor_options, anchor_value, eas, pct_error
from benchmarks.tsd_ams_gap import analyse
from romams.services.evaluation import Models, structure_modal
from romams.services.flight import FlightCondition
from romams.services.training import rom_identity
from romams_core.anchors import harmonic_anchors
from romams_core.basis import project
from romams_core.evaluate import evaluate_structure
from romams_core.projection_residual import PROJECTION_CORRECTIONS, ResidualCorrection
from romams_core.training_tsd import make_tsd_solver
from romams_core.wing import cropped_delta

#: the optimum of the full TSD paper case (150 generations, docs/optimization.md 3a), in the variables' own units
TSD_OPTIMUM = (0.1774, 0.6427, 0.8254, 0.0657, 1.997, 1.978, 0.5323)
SOLVER_OPTIONS = ("thickness_form", "thickness_to_chord", "grid_scale", "coefficients")


def setup(x: tuple[float, ...], options: dict[str, Any] | None = None) -> tuple[Models, Any, dict[str, Any]]:
    """(models without ROMs, the design's modal result, ROM identity) of the paper case (eccentric beam): its basis
    with ``paper_case.build_models``' defaults, no Mach trained."""
    wing = cropped_delta(beam_placement="eccentric")
    ident = rom_identity("tsd", options=options, wing=wing)
    models, _ = pc.build_models(wing, [], ident)
    return models, structure_modal(models, list(x)), ident


def _job(args: tuple[str, tuple[float, ...], float, tuple[float, ...], Path, dict[str, Any]]
         ) -> tuple[str, Any, float]:
    """Worker body: "basis" | "modes" trains (or reads) that ROM into the ROM directory; "direct" runs the modes."""
    kind, x, mach, ks, rom_dir, options = args
    t0 = time.perf_counter()
    models, modal, ident = setup(x, options)
    if kind == "direct":  # kept next to the ROMs: a rerun (other analysis, more Machs) reads it
        path = rom_dir / f"direct-M{mach:g}-k{'-'.join(f'{k:g}' for k in ks)}-x{'-'.join(f'{v:g}' for v in x)}.npy"
        if path.exists():
            out = np.load(path)
        else:
            options = {k: v for k, v in ident["options"].items() if k in SOLVER_OPTIONS}
            out = harmonic_anchors(make_tsd_solver(**options), models.mesh, modal.shapes, mach, np.asarray(ks))
            rom_dir.mkdir(parents=True, exist_ok=True)
            np.save(path, out)
    else:
        shapes = models.basis.shapes if kind == "basis" else modal.shapes
        pc.Trainer(1, rom_dir).roms(models.mesh, shapes, [mach], ident)
        out = None
    return kind, out, time.perf_counter() - t0


def run(mach: float, ks: tuple[float, ...], x: tuple[float, ...], rom_dir: Path, processes: int = 2,
        options: dict[str, Any] | None = None, projection_correction: str = "auto") -> dict[str, Any]:
    """Train / read both ROMs, run the direct columns, compare (module docstring); a JSON-able dict."""
    t0 = time.perf_counter()
    jobs = [(kind, x, mach, ks, rom_dir, options or {}) for kind in ("basis", "direct", "modes")]
    with get_context("spawn").Pool(processes) as pool:
        done = {kind: (out, sec) for kind, out, sec in pool.imap_unordered(_job, jobs)}
    models, modal, ident = setup(x, options)
    trainer = pc.Trainer(1, rom_dir)
    (rom_b,) = trainer.roms(models.mesh, models.basis.shapes, [mach], ident)
    (rom_p,) = trainer.roms(models.mesh, modal.shapes, [mach], ident)
    models = Models(0, models.wing, models.mesh, 0, models.basis, {mach: (0, rom_b)})
    condition = FlightCondition.from_options(projection_correction=projection_correction)
    ams, pms, _, _ = pc.ams_and_pms(models, list(x), ident, pc.Memo(), trainer, condition)
    (table8,) = pc.comparison_rows(ams, pms)
    gamma = project(models.basis.shapes, modal.shapes).gamma
    direct = done["direct"][0]
    res: dict[str, Any] = {
        "mach": mach, "k": list(ks), "x": list(x), "rom_identity": ident, "c_ref": models.mesh.c_ref,
        "omega": [float(w) for w in modal.omega], "n_basis": int(models.basis.n_basis),
        "states": {"basis": int(rom_b.ss.n_states), "modes": int(rom_p.ss.n_states)},
        "validation_nrmse_pct": {"basis": [100 * float(v) for v in rom_b.validation_nrmse],
                                 "modes": [100 * float(v) for v in rom_p.validation_nrmse]},
        "state_space": table8, "seconds": {kind: sec for kind, (_, sec) in done.items()}}
    res.update(analyse(rom_b, rom_p, gamma, modal.omega, models.mesh.c_ref, mach, models.wing.modal_damping,
                       np.asarray(ks), direct))
    # against both corrected ROMs' points (analyse's own *_vs_tsd_pct take the corrected basis ROM's): their spread
    # is how firmly the TSD point is known
    res["flutter"]["state_space_vs_tsd_pct"] = {
        name: {f"{ref}_corrected": pct_error(table8[f"v_eas_rom_{name}"], res["flutter"][f"{ref}_corrected"]["v_eas"])
               for ref in ("ams", "pms")} for name in ("ams", "pms")}
    res["wall_s"] = time.perf_counter() - t0
    return res


def basis_only(mach: float, x: tuple[float, ...], rom_dir: Path, reference: float,
               options: dict[str, Any] | None = None) -> dict[str, Any]:
    """The basis ROM alone, trained (or read) with the product's identity (its default anchors, docs/transonic.md
    7.11): its ROM-AMS flutter of the design by the state-space search against a known TSD point (EAS m/s)."""
    t0 = time.perf_counter()
    models, modal, ident = setup(x, options)
    (rom,) = pc.Trainer(1, rom_dir).roms(models.mesh, models.basis.shapes, [mach], ident)
    res, corr = (evaluate_structure(modal, models.basis.shapes, {mach: (rom.ss, rom.c_ref)},
                                    zeta=models.wing.modal_damping, residual=r).flutter[0]
                 for r in (None, ResidualCorrection(models.mesh)))
    v = eas(res.q_flutter_pa) if res.flutter_found else None
    v_corr = eas(corr.q_flutter_pa) if corr.flutter_found else None
    return {"mach": mach, "x": list(x), "rom_identity": ident, "states": int(rom.ss.n_states),
            "anchor_k": None if rom.anchor_k is None else [float(k) for k in rom.anchor_k],
            "anchor_band_error_pct": None if rom.anchor_band_error is None else 100 * rom.anchor_band_error,
            "validation_nrmse_pct": [100 * float(v) for v in rom.validation_nrmse], "train_seconds": rom.train_seconds,
            "v_eas_rom_ams": v, "omega_flutter_rad_s": res.omega_flutter_rad_s, "k_flutter": res.k_flutter,
            "flutter_mode": res.flutter_mode, "reference_v_eas": reference, "vs_tsd_pct": pct_error(v, reference),
            "v_eas_rom_ams_dlm_residual": v_corr, "dlm_residual_vs_tsd_pct": pct_error(v_corr, reference),
            "warnings": list(rom.warnings), "wall_s": time.perf_counter() - t0}


def main() -> None:
    """CLI entry point."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--mach", type=float, default=0.91)
    ap.add_argument("--k", type=float, nargs="+", default=[0.035, 0.05, 0.07],
                    help="direct TSD tones (reduced on c_ref / 2; bracket both ROMs' flutter k)")
    ap.add_argument("--x", type=float, nargs=7, default=list(TSD_OPTIMUM), help="the design (own units)")
    ap.add_argument("--rom-dir", type=Path, required=True, help="the ROMs, kept and reused (paper_case --rom-dir)")
    ap.add_argument("--processes", type=int, default=2)
    ap.add_argument("--reference", type=float, default=None, metavar="V_EAS",
                    help="only the basis ROM (product identity, default anchors) against this known TSD point (m/s)")
    ap.add_argument("--anchor-k", type=anchor_value, nargs="+", default=None,
                    help="the ROMs' anchor_k ('none': plain ROMs, as in docs/transonic.md 7.10; default: the "
                         "training's default anchors)")
    ap.add_argument("--projection-correction", default="auto", choices=PROJECTION_CORRECTIONS,
                    help="for the state-space ROM-AMS row (Table 8): the DLM projection residual (auto: on TSD ROMs; "
                         "none as in docs/transonic.md 7.10)")
    a = ap.parse_args()
    options = anchor_options(a.anchor_k)
    if a.reference is not None:
        print(json.dumps(basis_only(a.mach, tuple(a.x), a.rom_dir, a.reference, options)))
        return
    print(json.dumps(run(a.mach, tuple(a.k), tuple(a.x), a.rom_dir, a.processes, options, a.projection_correction)))


if __name__ == "__main__":
    main()
