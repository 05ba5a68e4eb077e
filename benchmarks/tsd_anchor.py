"""Anchoring a TSD basis ROM to direct harmonic runs of the basis shapes at low k (prints JSON).

ROM-AMS needs the basis ROM right where a design's flutter is decided; on the cropped delta at M 0.95 that is
k 0.05-0.06, where the ARX fit of an 8-shape basis scatters by several percent (docs/transonic.md 7.2). Here the
basis ROM (``benchmarks.accuracy_rom_ams``'s basis, default TSD settings) is trained once; each basis shape is
then run alone in the TSD with a two-tone motion at the ``--k`` pair (one run gives the shape's GAF column at
both: the analysis window is one period of the lower tone, a whole number of periods of both). The ARX models of
``--orders`` (refits on the training's records, full realizations) get their output map refitted to the records
subject to reproducing those columns exactly (``statespace.refit_output_map`` with anchors). Reported per order,
plain and anchored: ROM-AMS flutter (p-k on the model's GAF, EAS m/s) of designs 0-2 against the TSD's own points
(``--reference``, the harmonic-corrected points of ``benchmarks.tsd_ams_gap``: 60.37 / 101.19 / 92.07 m/s at M
0.95) and the free-run validation NRMSE on the training's validation record.

    python -m benchmarks.tsd_anchor [--mach 0.95] [--k 0.05 0.1] [--orders 6 8 10 12]
        [--reference 60.37 101.19 92.07] [--processes 2] [--out DIR]
"""

from __future__ import annotations

import argparse
import json
import math
import pickle
import time
from multiprocessing import get_context
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.tsd_ams_gap import _setup, refit
from benchmarks.tsd_excitation import REFERENCE_M095, ams_flutter
from benchmarks.tsd_harmonic_check import PEAK, tone_amplitudes
from romams.services.training import rom_identity, section_options, train
from romams_core.arx import nrmse
from romams_core.statespace import refit_output_map
from romams_core.training_tsd import make_tsd_solver


def two_tone_column(solver: Any, mesh: Any, shapes: np.ndarray, mach: float, ks: tuple[float, ...], col: int,
                    dts: float = 0.1) -> np.ndarray:
    """GAF columns [n_k, m] (m^3 per unit generalized displacement) of shape ``col`` moving alone at the tones ks
    (reduced frequency on c_ref / 2): a one-period ramp of the lowest tone, a quarter period for the transient of
    the ramp's end to leave, then one analysed period."""
    om = 2.0 * np.asarray(ks, dtype=float)
    period = 2.0 * math.pi / om.min()
    t = np.arange(int(round(2.25 * period / dts)) + 1) * dts
    ramp = np.minimum(1.0, t / period)
    sig = np.zeros((t.size, shapes.shape[1]))
    amp = PEAK * mesh.c_ref / np.abs(shapes[:, col]).max() / om.size
    sig[:, col] = amp * np.sin(np.outer(t, om)).sum(axis=1) * ramp
    gac = solver.simulate(mesh, shapes, sig, mach, dts)
    last = t >= t[-1] - period
    return tone_amplitudes(gac[last], t[last], om) / tone_amplitudes(sig[last, col], t[last], om)[:, None]


def _task(args: tuple[str, int, float, tuple[float, ...]]) -> tuple[tuple[str, int], Any, float]:
    """Worker: ("train", -1, mach, -) the basis ROM; ("tone", j, mach, ks) basis shape j's two-tone run."""
    kind, col, mach, ks = args
    t0 = time.perf_counter()
    wing, mesh, basis, _ = _setup(0)
    if kind == "train":
        out = train(mesh, basis.shapes, mach, rom_identity("tsd", wing=wing))
    else:
        out = two_tone_column(make_tsd_solver(**section_options(wing)), mesh, basis.shapes, mach, ks, col)
    return (kind, col), out, time.perf_counter() - t0


def run(mach: float = 0.95, ks: tuple[float, ...] = (0.05, 0.1), orders: tuple[int, ...] = (6, 8, 10, 12),
        reference: tuple[float, ...] = REFERENCE_M095, processes: int = 2, out: Path | None = None) -> dict[str, Any]:
    """Train, run the tones, refit with and without anchors, compare; a JSON-able dict (``out``: keep the ROM and
    the direct columns there as roms.pkl for further fits without a TSD run)."""
    t0 = time.perf_counter()
    _, _, basis, _ = _setup(0)
    m = basis.shapes.shape[1]
    jobs = [("train", -1, mach, ks)] + [("tone", j, mach, ks) for j in range(m)]
    with get_context("spawn").Pool(processes) as pool:
        done = {key: (val, sec) for key, val, sec in pool.imap_unordered(_task, jobs)}
    rom = done[("train", -1)][0]
    direct = np.stack([done[("tone", j)][0] for j in range(m)], axis=2)  # [n_k, m, m]: column j from run j
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        with open(out / "roms.pkl", "wb") as fh:
            pickle.dump({"basis": rom, "k": np.array(ks), "direct": direct}, fh)
    setups = [_setup(d) for d in range(len(reference))]
    res: dict[str, Any] = {"mach": mach, "k": list(ks), "na": rom.na, "nb": rom.nb, "reference": list(reference),
                           "seconds": {f"{kind}{'' if c < 0 else c}": sec for (kind, c), (_, sec) in done.items()},
                           "trained_model_error_at_k_of_max_pct": [float(100 * np.abs(h - d).max() / np.abs(d).max())
                                                                    for h, d in zip(rom.ss.freqresp(np.array(ks)),
                                                                                    direct, strict=True)],
                           "fits": []}
    for order in orders:
        ss = refit(rom, order)
        row: dict[str, Any] = {"order": order, "stable": ss is not None}
        if ss is not None:
            row["n_states"] = ss.n_states
            anchored = refit_output_map(ss, rom.signals_train, rom.gac_train, np.array(ks), direct)
            for name, model in (("plain", ss), ("anchored", anchored)):
                row[name] = {**ams_flutter(model, setups, reference, mach), "validation_nrmse_max_pct": float(
                    100 * nrmse(rom.gac_validation, model.simulate(rom.signals_validation)).max())}
        res["fits"].append(row)
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
    a = ap.parse_args()
    print(json.dumps(run(a.mach, tuple(a.k), tuple(a.orders), tuple(a.reference), a.processes, a.out), indent=1))


if __name__ == "__main__":
    main()
