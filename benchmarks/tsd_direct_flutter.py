"""A design's TSD flutter point with no ROM at all: p-k on the transfer matrix of step records (prints JSON).

One step record per shape (``anchors.step_anchors``: each shape raised alone and held, docs/transonic.md 7.11)
gives the TSD's discrete transfer matrix at every reduced frequency at once. The shapes run here are the design's
own modes and the basis shapes together, and every record's generalized forces are taken on all of them, so one
set of runs gives, on a k grid from 0 to ``--k-max``:
- ``direct``: the modes' own transfer matrix G_mm: p-k on it is the TSD's flutter point of the design, with no
  identification and no correction held outside anchors (7.10's reference construction);
- ``projected``: gamma^T G_bb gamma, the basis shapes' matrix projected on the modes: what an exact ROM-AMS gives
  (every basis ROM can at best reproduce G_bb);
- ``mixed``: G_mb gamma, forces on the true modes from the basis motion: separates the motion's projection
  (right) from the force integration (left).

The difference between ``direct`` and ``projected`` is the projection error of ROM-AMS on this design, free of
identification error. The DLM's transfer matrix of the same shapes (``DLM_K``, seconds) gives the DLM's own
``dlm_direct`` / ``dlm_projected`` points and ``hybrid``: the TSD's projected matrix plus the DLM's residual
G_dlm(Phi) - G_dlm(Phi_fit), what ``projection_correction: dlm`` adds (docs/transonic.md 7.12).
Default design: the paper case's TSD optimum (``tsd_optimum_check.TSD_OPTIMUM``).

    python -m benchmarks.tsd_direct_flutter --mach 0.95 [--x X1 .. X7] [--hold 120] [--out DIR]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.tsd_ams_gap import pk_point
from benchmarks.tsd_optimum_check import SOLVER_OPTIONS, TSD_OPTIMUM, setup
from romams_core.aero.dlm import frequency_response
from romams_core.anchors import STEP_HOLD, step_anchors
from romams_core.basis import project
from romams_core.pk import AeroTable
from romams_core.training_tsd import make_tsd_solver

#: the DLM's reduced frequencies for the hybrid tables (the TSD tables are interpolated onto them)
DLM_K = np.concatenate([[0.0, 0.005], np.arange(0.01, 0.2, 0.01), np.arange(0.2, 1.01, 0.05)])


def transfer_table(x: tuple[float, ...], mach: float, k: np.ndarray, hold: float, out: Path | None
                   ) -> tuple[np.ndarray, Any, Any]:
    """(transfer matrix [nk, n, n] of [modes | basis shapes] at k, models, modal), from ``out`` if kept there."""
    models, modal, ident = setup(x)
    path = None if out is None else out / f"steps-M{mach:g}-h{hold:g}-x{'-'.join(f'{v:g}' for v in x)}.npz"
    if path is not None and path.exists():
        kept = np.load(path)
        if np.array_equal(kept["k"], k):
            return kept["gaf"], models, modal
    shapes = np.hstack([modal.shapes, models.basis.shapes])
    solver = make_tsd_solver(**{key: v for key, v in ident["options"].items() if key in SOLVER_OPTIONS})
    gaf = step_anchors(solver, models.mesh, shapes, mach, k, hold=hold)  # the training's signal step and amplitude
    if path is not None:
        out.mkdir(parents=True, exist_ok=True)
        np.savez(path, k=k, gaf=gaf)
    return gaf, models, modal


def run(mach: float, x: tuple[float, ...], hold: float = STEP_HOLD, k_max: float = 2.0, dk: float = 0.005,
        out: Path | None = None) -> dict[str, Any]:
    """Step records of the design's modes and the basis, p-k on the direct, projected and mixed matrices."""
    t0 = time.perf_counter()
    k = np.round(np.arange(0.0, k_max + 0.5 * dk, dk), 9)
    gaf, models, modal = transfer_table(x, mach, k, hold, out)
    n = modal.shapes.shape[1]
    proj = project(models.basis.shapes, modal.shapes)
    gamma = proj.gamma
    tables = {"direct": gaf[:, :n, :n], "projected": np.einsum("bi,kbc,cj->kij", gamma, gaf[:, n:, n:], gamma),
              "mixed": gaf[:, :n, n:] @ gamma}
    zeta = models.wing.modal_damping
    c_ref = models.mesh.c_ref
    dlm = frequency_response(models.mesh, np.hstack([modal.shapes, models.basis.shapes]), mach, DLM_K)
    dlm_direct, dlm_projected = dlm[:, :n, :n], np.einsum("bi,kbc,cj->kij", gamma, dlm[:, n:, n:], gamma)
    on_dlm_k = {name: AeroTable(k, tables[name])(DLM_K) for name in ("direct", "projected")}
    dlm_tables = {"dlm_direct": dlm_direct, "dlm_projected": dlm_projected,
                  "hybrid": on_dlm_k["projected"] + dlm_direct - dlm_projected}
    res: dict[str, Any] = {"mach": mach, "x": list(x), "hold": hold, "k_max": k_max, "dk": dk,
                           "omega": [float(w) for w in modal.omega], "n_basis": int(models.basis.n_basis),
                           "mac": [float(v) for v in proj.mac], "flutter": {}, "entries": []}
    for name, h in tables.items():
        res["flutter"][name] = pk_point(AeroTable(k, h), modal.omega, c_ref, mach, zeta)
    for name, h in dlm_tables.items():
        res["flutter"][name] = pk_point(AeroTable(DLM_K, h), modal.omega, c_ref, mach, zeta)
    i = int(np.argmin(np.abs(DLM_K - 0.06)))
    res["hybrid_err_of_max_pct_k006"] = float(100 * np.abs(dlm_tables["hybrid"][i] - on_dlm_k["direct"][i]).max()
                                              / np.abs(on_dlm_k["direct"][i]).max())
    v_direct = res["flutter"]["direct"]["v_eas"]
    for name in ("projected", "mixed", "hybrid"):
        v = res["flutter"][name]["v_eas"]
        res["flutter"][f"{name}_vs_direct_pct"] = None if v is None or v_direct is None else 100 * (v / v_direct - 1)
    scale = np.abs(tables["direct"]).max(axis=(1, 2))
    for kk in (0.025, 0.05, 0.063, 0.075, 0.1, 0.2, 0.4):
        i = int(np.argmin(np.abs(k - kk)))
        d = tables["direct"][i]
        row: dict[str, Any] = {"k": float(k[i])}
        for name in ("projected", "mixed"):
            row[f"{name}_err_of_max_pct"] = float(100 * np.abs(tables[name][i] - d).max() / scale[i])
            ratio = np.diag(tables[name][i]) / np.diag(d)
            row[f"{name}_diag_ratio"] = [[round(float(abs(r)), 5), round(float(np.degrees(np.angle(r))), 3)]
                                         for r in ratio]
        res["entries"].append(row)
    res["wall_s"] = time.perf_counter() - t0
    return res


def main() -> None:
    """CLI entry point."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--mach", type=float, default=0.95)
    ap.add_argument("--x", type=float, nargs=7, default=list(TSD_OPTIMUM), help="the design (own units)")
    ap.add_argument("--hold", type=float, default=STEP_HOLD, help="step hold (t*)")
    ap.add_argument("--k-max", type=float, default=2.0, help="top of the p-k table (reduced on c_ref / 2)")
    ap.add_argument("--out", type=Path, default=None, help="keep (and reuse) the transfer table here")
    a = ap.parse_args()
    print(json.dumps(run(a.mach, tuple(a.x), a.hold, a.k_max, out=a.out)))


if __name__ == "__main__":
    main()
