"""How the training signal's spectrum moves a TSD basis ROM's flutter points (prints JSON).

Trains the cropped-delta 8-shape basis ROM (``benchmarks.accuracy_rom_ams``'s basis and designs) at one Mach for
each ``--corner`` (``low_k_corner`` of ``signals.multisine``: 0 is the flat spectrum, c raises the power below
k = c as 1 / k), refits ARX models of ``--orders`` on each training's own records (seconds each; no new TSD run),
and reports ROM-AMS flutter (p-k on each model's GAF, EAS m/s) of designs 0-2 against the TSD's own flutter
points on those designs (``--reference``: the harmonic-corrected points of ``benchmarks.tsd_ams_gap``, measured
at M 0.95 in docs/transonic.md 7.2: 60.37 / 101.19 / 92.07 m/s). One process per corner. The ROMs are plain
(``anchor_k`` None): anchors, the TSD default since 2026-12-04, would hide the spectrum's effect at low k.

    python -m benchmarks.tsd_excitation [--mach 0.95] [--corner 0 0.1] [--na 14 --nb 14] [--orders 8 10 12 14 16]
        [--reference 60.37 101.19 92.07] [--processes 2]
"""

from __future__ import annotations

import argparse
import json
import time
from multiprocessing import get_context
from typing import Any

import numpy as np

from benchmarks.accuracy_rom_ams import pct_error
from benchmarks.tsd_ams_gap import _setup, pk_point, refit
from romams.services.training import rom_identity, train
from romams_core.arx import nrmse
from romams_core.basis import project
from romams_core.statespace import DiscreteSS, to_modal

#: the TSD's own flutter points (EAS m/s) of designs 0, 1, 2 at M 0.95 (benchmarks.tsd_ams_gap, docs/transonic.md 7.2)
REFERENCE_M095 = (60.37, 101.19, 92.07)


def _train(args: tuple[float, float, int, int]) -> tuple[float, Any, float]:
    """Worker: the basis ROM at ``mach`` with ``low_k_corner`` = corner and orders na/nb."""
    mach, corner, na, nb = args
    t0 = time.perf_counter()
    wing, mesh, basis, _ = _setup(0)
    options: dict[str, Any] = {"anchor_k": None}  # plain ROMs: the study is of the identification's own scatter
    if corner > 0:
        options["low_k_corner"] = corner
    rom = train(mesh, basis.shapes, mach, rom_identity("tsd", na, nb, options=options, wing=wing))
    return corner, rom, time.perf_counter() - t0


def ams_flutter(ss: DiscreteSS, setups: list[Any], reference: tuple[float, ...], mach: float) -> dict[str, Any]:
    """ROM-AMS p-k flutter (EAS m/s) of each design (``tsd_ams_gap._setup``) through the basis model ``ss`` and its
    error against the reference (%)."""
    v = []
    for wing, mesh, basis, modal in setups:
        ams = to_modal(ss, project(basis.shapes, modal.shapes).gamma)
        v.append(pk_point(lambda k, s=ams: s.freqresp(np.atleast_1d(k)), modal.omega, mesh.c_ref, mach,
                          wing.modal_damping)["v_eas"])
    return {"v_eas": v, "vs_tsd_pct": [pct_error(a, r) for a, r in zip(v, reference, strict=True)]}


def run(mach: float = 0.95, corners: tuple[float, ...] = (0.0, 0.1), na: int = 14, nb: int = 14,
        orders: tuple[int, ...] = (8, 10, 12, 14, 16), reference: tuple[float, ...] = REFERENCE_M095,
        processes: int = 2) -> dict[str, Any]:
    """Train, refit and compare (see the module docstring); a JSON-able dict."""
    t0 = time.perf_counter()
    with get_context("spawn").Pool(processes) as pool:
        trained = pool.map(_train, [(mach, c, na, nb) for c in corners])
    setups = [_setup(d) for d in range(len(reference))]
    out: dict[str, Any] = {"mach": mach, "na": na, "nb": nb, "reference": list(reference), "corners": []}
    for corner, rom, seconds in trained:
        fits: list[dict[str, Any]] = []
        for order in orders:
            ss = rom.ss if order == na == nb else refit(rom, order)
            if ss is None:
                fits.append({"order": order, "unstable": True})
                continue
            fits.append({"order": order, "validation_nrmse_max_pct": float(100 * nrmse(
                rom.gac_validation, ss.simulate(rom.signals_validation)).max()),
                **ams_flutter(ss, setups, reference, mach)})
        ok = [abs(e) for f in fits for e in f.get("vs_tsd_pct", []) if e is not None]
        out["corners"].append({"low_k_corner": corner, "train_seconds": seconds, "n_steps": int(rom.gac_train.shape[0]),
                               "validation_nrmse_max_pct": float(100 * np.max(rom.validation_nrmse)),
                               "fits": fits, "worst_abs_vs_tsd_pct": max(ok) if ok else None})
    out["wall_s"] = time.perf_counter() - t0
    return out


def main() -> None:
    """CLI entry point."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--mach", type=float, default=0.95)
    ap.add_argument("--corner", type=float, nargs="+", default=[0.0, 0.1])
    ap.add_argument("--na", type=int, default=14)
    ap.add_argument("--nb", type=int, default=14)
    ap.add_argument("--orders", type=int, nargs="+", default=[8, 10, 12, 14, 16])
    ap.add_argument("--reference", type=float, nargs="+", default=list(REFERENCE_M095))
    ap.add_argument("--processes", type=int, default=2)
    a = ap.parse_args()
    print(json.dumps(run(a.mach, tuple(a.corner), a.na, a.nb, tuple(a.orders), tuple(a.reference), a.processes),
                     indent=1))


if __name__ == "__main__":
    main()
