"""Flutter-search regression and timing set: 30 random cropped-delta designs x 5 Machs, printed as JSON.

``build`` trains the 8-shape basis (MAC 0.9999) and UVLM ROMs at the paper's Machs once and stores the
inputs of every flutter search (structural omega [k], projection gamma [m, k], ROM matrices, c_ref) in an
NPZ, so that later runs are bit-for-bit reproducible (ROM training is not). ``record`` runs every search
for several sweep/coupling/damping cases and writes the flutter points (q_f, V_f, omega_f, mode, SDOFF)
and per-structure CPU times of the flutter searches; ``structure`` times the whole per-structure evaluation
(modal analysis + evaluate_structure); ``compare`` checks a record against a reference record (max relative
deviation per field, mode and SDOFF mismatches). Usage:

    python -m benchmarks.flutter_regression build  [--fixture F.npz] [--designs 30]
    python -m benchmarks.flutter_regression record [--fixture F.npz] --out R.json [--repeat 3] [--batched]
                                                   [--tracking eigen|continuation]
    python -m benchmarks.flutter_regression structure [--fixture F.npz] [--repeat 3]
    python -m benchmarks.flutter_regression compare REF.json NEW.json
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core, before numpy loads its BLAS

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

DEFAULT_FIXTURE = Path(".romams") / "flutter_regression.npz"
# (name, flutter_analysis keywords); the first is the production path (the template's zeta = 0)
CASES: tuple[tuple[str, dict[str, Any]], ...] = (
    ("speed/tustin/z0", {"sweep": "constant-speed", "coupling": "tustin", "zeta": None}),
    ("speed/tustin/z0.01", {"sweep": "constant-speed", "coupling": "tustin", "zeta": 0.01}),
    ("matched/tustin/z0.01", {"sweep": "matched", "coupling": "tustin", "zeta": 0.01}),
    ("density/tustin/z0.01", {"sweep": "constant-density", "coupling": "tustin", "zeta": 0.01}),
    ("speed/zoh/z0.01", {"sweep": "constant-speed", "coupling": "zoh", "zeta": 0.01}),
)
FIELDS = ("q_flutter_pa", "v_flutter_m_s", "omega_flutter_rad_s")


def build(fixture: Path, n_designs: int, seed: int = 1) -> dict[str, Any]:
    """Train basis and ROMs, run the modal analyses of ``n_designs`` random designs, store the search inputs."""
    from romams.pipeline import PAPER_MACHS, rom_identity, train_shapes
    from romams_core.basis import build_basis_for_wing, project, random_designs
    from romams_core.mesh import standard_mesh
    from romams_core.structure.modal import modal_analysis
    from romams_core.wing import template

    wing = template("cropped-delta")
    mesh = standard_mesh(wing.planform)
    t0 = time.perf_counter()
    basis = build_basis_for_wing(wing, 25, 4, 0.9999, 8)
    roms = train_shapes(mesh, basis.shapes, PAPER_MACHS, rom_identity("uvlm"), 2)  # discrete ARX ROMs (dt_star)
    t_train = time.perf_counter() - t0
    designs = random_designs(wing, n_designs, seed=seed)
    omegas, gammas = [], []
    for x in designs:
        modal = modal_analysis(wing, x, 4, mesh)
        omegas.append(modal.omega)
        gammas.append(project(basis.shapes, modal.shapes).gamma)
    data: dict[str, Any] = {"machs": np.asarray(PAPER_MACHS), "designs": designs, "omega": np.asarray(omegas),
                            "gamma": np.asarray(gammas), "c_ref": np.asarray([r.c_ref for r in roms])}
    for i, r in enumerate(roms):
        for n in ("A", "B", "C", "D"):
            data[f"rom{i}_{n}"] = np.asarray(getattr(r.ss, n))
        data[f"rom{i}_dt_star"] = np.asarray(r.ss.dt_star)
    fixture.parent.mkdir(parents=True, exist_ok=True)
    np.savez(fixture, **data)
    return {"fixture": str(fixture), "designs": n_designs, "n_basis": int(basis.n_basis),
            "rom_states": [int(r.ss.A.shape[0]) for r in roms], "build_s": t_train}


def load(fixture: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[Any], np.ndarray]:
    """(machs, omega [n, k], gamma [n, m, k], ROMs in basis coordinates, c_ref) of a fixture."""
    from romams_core.statespace import DiscreteSS

    z = np.load(fixture)
    machs = z["machs"]
    roms = [DiscreteSS(A=z[f"rom{i}_A"], B=z[f"rom{i}_B"], C=z[f"rom{i}_C"], D=z[f"rom{i}_D"],
                       dt_star=float(z[f"rom{i}_dt_star"])) for i in range(machs.size)]
    return machs, z["omega"], z["gamma"], roms, z["c_ref"]


def _row(r: Any) -> dict[str, Any]:
    """JSON row of a FlutterResult."""
    return {"found": bool(r.flutter_found), "mode": r.flutter_mode, "sdoff": bool(r.sdoff),
            **{f: (None if getattr(r, f) is None else float(getattr(r, f))) for f in FIELDS}}


def record(fixture: Path, repeat: int = 1, cases: list[str] | None = None, batched: bool = False,
           tracking: str | None = None) -> dict[str, Any]:
    """Flutter points of every design x Mach x case and per-structure CPU time medians (ms).

    ``batched``: at each Mach the searches of all designs run as one batch (``flutter_batch``); the CPU time of a
    structure is then the batch's time over the number of designs. ``tracking``: the flutter option (None: default).
    """
    from romams_core.flutter import flutter_analysis, flutter_batch
    from romams_core.statespace import to_modal

    machs, omega, gamma, roms, c_ref = load(fixture)
    n = omega.shape[0]
    out: dict[str, Any] = {"fixture": str(fixture), "designs": int(n), "machs": machs.tolist(), "cases": {},
                           "batched": batched, "tracking": tracking}
    for name, kw in CASES:
        if cases and name not in cases:
            continue
        if tracking is not None:
            kw = dict(kw, tracking=tracking)
        rows: list[list[dict[str, Any]]] = []
        cpu = []
        for rep in range(repeat):
            if batched:
                t0 = time.process_time()
                res_m = [flutter_batch([(omega[i], to_modal(roms[j], gamma[i])) for i in range(n)], float(c_ref[j]),
                                       float(machs[j]), **kw) for j in range(machs.size)]
                cpu.append((time.process_time() - t0) / n)
                if rep == 0:
                    rows = [[_row(res_m[j][i]) for j in range(machs.size)] for i in range(n)]
                continue
            for i in range(n):
                t0 = time.process_time()
                res = [flutter_analysis(omega[i], to_modal(roms[j], gamma[i]), float(c_ref[j]), float(machs[j]), **kw)
                       for j in range(machs.size)]
                cpu.append(time.process_time() - t0)
                if rep == 0:
                    rows.append([_row(r) for r in res])
        out["cases"][name] = {"rows": rows, "cpu_ms_median_5machs": 1e3 * float(np.median(cpu)),
                              "cpu_ms_p90_5machs": 1e3 * float(np.percentile(cpu, 90))}
    return out


def structure(fixture: Path, repeat: int = 3) -> dict[str, Any]:
    """CPU time per structure (modal analysis + evaluate_structure at the fixture's Machs), medians in ms.

    The basis is rebuilt (deterministic) and checked against the fixture's projections.
    """
    from romams_core.basis import build_basis_for_wing, project
    from romams_core.evaluate import evaluate_structure
    from romams_core.mesh import standard_mesh
    from romams_core.structure.modal import modal_analysis
    from romams_core.wing import template

    machs, omega, gamma, roms, c_ref = load(fixture)
    designs = np.load(fixture)["designs"]
    wing = template("cropped-delta")
    mesh = standard_mesh(wing.planform)
    basis = build_basis_for_wing(wing, 25, 4, 0.9999, 8)
    first = modal_analysis(wing, designs[0], 4, mesh)
    if not np.allclose(np.abs(project(basis.shapes, first.shapes).gamma), np.abs(gamma[0]), rtol=1e-6, atol=1e-9):
        raise SystemExit("fixture: the rebuilt basis does not match the one the ROMs were trained on")
    rom_map = {float(m): (r, float(c)) for m, r, c in zip(machs, roms, c_ref, strict=True)}
    zeta = wing.modal_damping or None
    modal_ms, flutter_ms, total_ms = [], [], []
    for _ in range(repeat):
        for x in designs:
            t0 = time.process_time()
            modal = modal_analysis(wing, x, 4, mesh)
            t1 = time.process_time()
            evaluate_structure(modal, basis.shapes, rom_map, mac_threshold=basis.mac_threshold, zeta=zeta)
            t2 = time.process_time()
            modal_ms.append(1e3 * (t1 - t0))
            flutter_ms.append(1e3 * (t2 - t1))
            total_ms.append(1e3 * (t2 - t0))
    return {"structure_cpu_ms_median": float(np.median(total_ms)),
            "structure_cpu_ms_p90": float(np.percentile(total_ms, 90)),
            "modal_cpu_ms_median": float(np.median(modal_ms)), "evaluate_cpu_ms_median": float(np.median(flutter_ms)),
            "designs": int(designs.shape[0]), "repeat": repeat, "machs": machs.tolist(), "target_ms": 50.0}


def compare(ref: dict[str, Any], new: dict[str, Any]) -> dict[str, Any]:
    """Max relative deviation of q_f, V_f, omega_f and mode/SDOFF/found mismatches of ``new`` against ``ref``."""
    out: dict[str, Any] = {}
    for name, case in new["cases"].items():
        if name not in ref["cases"]:
            continue
        dev = dict.fromkeys(FIELDS, 0.0)
        mism: list[str] = []
        for i, (ra, rb) in enumerate(zip(ref["cases"][name]["rows"], case["rows"], strict=True)):
            for j, (a, b) in enumerate(zip(ra, rb, strict=True)):
                tag = f"design {i} mach {j}"
                for key in ("found", "mode", "sdoff"):
                    if a[key] != b[key]:
                        mism.append(f"{tag}: {key} {a[key]} -> {b[key]}")
                if a["found"] and b["found"]:
                    for f in FIELDS:
                        d = abs(b[f] - a[f]) / max(abs(a[f]), 1e-300)
                        dev[f] = max(dev[f], d if math.isfinite(d) else math.inf)
        out[name] = {"max_rel_dev": dev, "mismatches": mism,
                     "cpu_ms_ref": ref["cases"][name]["cpu_ms_median_5machs"],
                     "cpu_ms_new": case["cpu_ms_median_5machs"]}
    return out


def main() -> None:
    """Command line (see the module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    b = sub.add_parser("build")
    b.add_argument("--fixture", type=Path, default=DEFAULT_FIXTURE)
    b.add_argument("--designs", type=int, default=30)
    r = sub.add_parser("record")
    r.add_argument("--fixture", type=Path, default=DEFAULT_FIXTURE)
    r.add_argument("--out", type=Path, required=True)
    r.add_argument("--repeat", type=int, default=1)
    r.add_argument("--case", action="append", default=None, help="only these cases (repeatable)")
    r.add_argument("--batched", action="store_true", help="each Mach's searches of all designs as one batch")
    r.add_argument("--tracking", choices=["eigen", "continuation"], default=None, help="branch tracker (default: "
                   "the flutter default)")
    st = sub.add_parser("structure")
    st.add_argument("--fixture", type=Path, default=DEFAULT_FIXTURE)
    st.add_argument("--repeat", type=int, default=3)
    c = sub.add_parser("compare")
    c.add_argument("ref", type=Path)
    c.add_argument("new", type=Path)
    args = ap.parse_args()
    if args.cmd == "build":
        print(json.dumps(build(args.fixture, args.designs), indent=2))
    elif args.cmd == "record":
        res = record(args.fixture, args.repeat, args.case, args.batched, args.tracking)
        args.out.write_text(json.dumps(res))
        print(json.dumps({k: {kk: vv for kk, vv in v.items() if kk != "rows"} for k, v in res["cases"].items()},
                         indent=2))
    elif args.cmd == "structure":
        print(json.dumps(structure(args.fixture, args.repeat), indent=2))
    else:
        print(json.dumps(compare(json.loads(args.ref.read_text()), json.loads(args.new.read_text())), indent=2))


if __name__ == "__main__":
    main()
