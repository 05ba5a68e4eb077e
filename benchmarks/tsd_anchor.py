"""Anchoring a TSD basis ROM to direct harmonic runs of the basis shapes at low k (prints JSON).

ROM-AMS needs the basis ROM right where a design's flutter is decided; on the cropped delta at M 0.95 that is
k 0.05-0.06, where the ARX fit of an 8-shape basis scatters by several percent (docs/transonic.md 7.2). Here the
basis ROM (``benchmarks.accuracy_rom_ams``'s basis, default TSD settings) is trained once, and beside it each
basis shape is run alone in the TSD with a multi-tone motion at the ``--k`` set (``anchors.harmonic_anchors``:
the columns of the transfer matrix there). The trained ROM and ARX refits of ``--orders`` on its records (full
realizations) are compared plain and with the lag correction that reproduces those columns exactly
(``anchors.anchored``, what the training option ``anchor_k`` does). Reported per model: ROM-AMS flutter of
designs 0-2 against the TSD's own points (``--reference``: 60.37 / 101.19 / 92.07 m/s EAS at M 0.95, the
harmonic-corrected points of ``benchmarks.tsd_ams_gap``), by p-k on the model's GAF and by the product's
state-space search (``evaluate_structure``, constant-speed sweep), and the free-run validation NRMSE.

    python -m benchmarks.tsd_anchor [--mach 0.95] [--k 0.05 0.1] [--orders 6 8 10 12]
        [--reference 60.37 101.19 92.07] [--processes 2] [--out DIR | --load DIR]

``--out DIR`` keeps the trained ROM and the direct columns in DIR/roms.pkl; ``--load DIR`` refits from there
without a TSD run (seconds).
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
from benchmarks.tsd_ams_gap import _setup, refit
from benchmarks.tsd_excitation import REFERENCE_M095, ams_flutter
from benchmarks.tsd_harmonic_check import PEAK
from romams.services.training import rom_identity, section_options, train
from romams_core.anchors import anchored, harmonic_anchors, step_anchors
from romams_core.arx import nrmse
from romams_core.evaluate import evaluate_structure
from romams_core.statespace import DiscreteSS
from romams_core.training_tsd import ANCHOR_BAND_K, make_tsd_solver


def _task(args: tuple[str, float, tuple[float, ...], str]) -> tuple[str, Any, float]:
    """Worker: ("train", mach, -, -) the plain basis ROM; ("anchors", mach, ks, method) the basis shapes' direct
    columns at ks (method "tones": ``harmonic_anchors``; "step": ``step_anchors``, the training's default)."""
    kind, mach, ks, method = args
    t0 = time.perf_counter()
    wing, mesh, basis, _ = _setup(0)
    if kind == "train":
        out = train(mesh, basis.shapes, mach, rom_identity("tsd", options={"anchor_k": None}, wing=wing))
    else:
        run_anchors = harmonic_anchors if method == "tones" else step_anchors
        out = run_anchors(make_tsd_solver(**section_options(wing)), mesh, basis.shapes, mach, np.array(ks),
                          peak_fraction=PEAK)
    return kind, out, time.perf_counter() - t0


def state_space_flutter(ss: DiscreteSS, c_ref: float, setups: list[Any], reference: tuple[float, ...],
                        mach: float) -> list[float | None]:
    """The product's ROM-AMS flutter (state-space search, constant-speed sweep) of each design: error against the
    reference (%), None where no flutter was found."""
    out = []
    for (wing, _, basis, modal), ref in zip(setups, reference, strict=True):
        res = evaluate_structure(modal, basis.shapes, {mach: (ss, c_ref)}, zeta=wing.modal_damping).flutter[0]
        out.append(pct_error(eas(res.q_flutter_pa), ref) if res.flutter_found else None)
    return out


def _compare(name: str, ss: DiscreteSS, rom: Any, setups: list[Any], reference: tuple[float, ...],
             mach: float) -> dict[str, Any]:
    """One model's row: states, validation NRMSE, p-k and state-space ROM-AMS errors against the reference."""
    val = nrmse(rom.gac_validation, ss.simulate(rom.signals_validation))
    return {"model": name, "n_states": ss.n_states, "stable": bool(ss.is_stable()),
            "validation_nrmse_max_pct": float(100 * val.max()),
            "pk_vs_tsd_pct": ams_flutter(ss, setups, reference, mach)["vs_tsd_pct"],
            "state_space_vs_tsd_pct": state_space_flutter(ss, rom.c_ref, setups, reference, mach)}


def run(mach: float = 0.95, ks: tuple[float, ...] = (0.05, 0.1), orders: tuple[int, ...] = (6, 8, 10, 12),
        reference: tuple[float, ...] = REFERENCE_M095, processes: int = 2, out: Path | None = None,
        load: Path | None = None, method: str = "tones") -> dict[str, Any]:
    """Train and run the tones or steps (or ``load`` them), correct, compare; a JSON-able dict."""
    t0 = time.perf_counter()
    band = ANCHOR_BAND_K if method == "step" else ()  # the step records give them at no cost
    seconds: dict[str, float] = {}
    if load is not None:
        with open(load / "roms.pkl", "rb") as fh:
            saved = pickle.load(fh)  # noqa: S301 - this benchmark's own file
        rom, direct, method = saved["basis"], saved["direct"], saved.get("method", "tones")
        band = tuple(float(k) for k in saved.get("band", ()))
        have = [float(k) for k in saved["k"]] + list(band)
        if not set(ks) <= set(have):  # other anchors: any k the saved runs hold (the step records' band)
            ks = tuple(float(k) for k in saved["k"])
        direct = np.concatenate([direct[[have.index(k) for k in ks]], direct[len(saved["k"]):]])
    else:
        with get_context("spawn").Pool(min(processes, 2)) as pool:
            done = {kind: (val, sec) for kind, val, sec in pool.imap_unordered(
                _task, [("train", mach, ks, method), ("anchors", mach, ks + band, method)])}
        (rom, seconds["train"]), (direct, seconds["anchors"]) = done["train"], done["anchors"]
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        with open(out / "roms.pkl", "wb") as fh:
            pickle.dump({"basis": rom, "k": np.array(ks), "direct": direct, "band": np.array(band), "method": method},
                        fh)
    direct, band_direct = direct[:len(ks)], direct[len(ks):]
    setups = [_setup(d) for d in range(len(reference))]
    k = np.array(ks)
    res: dict[str, Any] = {"mach": mach, "k": list(ks), "method": method, "na": rom.na, "nb": rom.nb,
                           "reference": list(reference),
                           "seconds": seconds, "trained_model_error_at_k_of_max_pct": [
                               float(100 * np.abs(h - d).max() / np.abs(d).max())
                               for h, d in zip(rom.ss.freqresp(k), direct, strict=True)], "models": []}
    models: list[tuple[str, DiscreteSS | None]] = [("trained", rom.ss)]
    models += [(f"refit {o}/{o}", refit(rom, o)) for o in orders]
    for name, ss in models:
        if ss is None:
            res["models"].append({"model": name, "stable": False})
            continue
        fixed = anchored(ss, k, direct)
        row = {"plain": _compare(name, ss, rom, setups, reference, mach),
               "anchored": _compare(name, fixed, rom, setups, reference, mach)}
        if band:  # error over the band, share of the largest entry at each k: what the training reports
            for key, model in (("plain", ss), ("anchored", fixed)):
                err = np.abs(model.freqresp(np.array(band)) - band_direct).max(axis=(1, 2))
                row[key]["band_error_pct"] = [round(float(v), 4) for v in
                                              100 * err / np.abs(band_direct).max(axis=(1, 2))]
        res["models"].append(row)
    res["band_k"] = list(band)
    res["wall_s"] = time.perf_counter() - t0
    return res


def main() -> None:
    """CLI entry point."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--mach", type=float, default=0.95)
    ap.add_argument("--k", type=float, nargs="+", default=[0.05, 0.1])
    ap.add_argument("--orders", type=int, nargs="+", default=[6, 8, 10, 12])
    ap.add_argument("--reference", type=float, nargs="+", default=list(REFERENCE_M095))
    ap.add_argument("--processes", type=int, default=2)
    ap.add_argument("--out", type=Path, default=None, help="directory for roms.pkl (the ROM and the direct columns)")
    ap.add_argument("--load", type=Path, default=None, help="directory of a roms.pkl to refit without a TSD run")
    ap.add_argument("--method", default="tones", choices=("tones", "step"),
                    help="direct columns from multi-tone runs or from one step record per shape (the training's)")
    a = ap.parse_args()
    print(json.dumps(run(a.mach, tuple(a.k), tuple(a.orders), tuple(a.reference), a.processes, a.out, a.load,
                         a.method), indent=1))


if __name__ == "__main__":
    main()
