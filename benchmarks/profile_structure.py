"""Where the time of one structure goes: cProfile of one structure alone and of one inside a batch of 30, as JSON.

    python -m benchmarks.profile_structure [--solver dlm|uvlm] [--designs 30] [--top 14] [--tracking eigen|continuation]

Builds the cropped-delta basis and ROMs at the paper's 5 Machs in process (as ``benchmarks.run``), then profiles
(one BLAS thread) modal analysis + ``evaluate_structure`` of ``--designs`` designs one at a time, and modal analysis
+ ``evaluate_structures`` of the same designs as one batch. Per case: CPU ms per structure without the profiler,
the ``--top`` functions by own time (ms per structure, calls per structure), full eigen-solves per Mach, LAPACK
eigenvalue calls per structure, and the eigenvalue floor (the solves x the median time of one 40 x 40 eigvals).
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core, before numpy loads its BLAS

import argparse  # noqa: E402
import cProfile  # noqa: E402
import json  # noqa: E402
import pstats  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable  # noqa: E402
from typing import Any  # noqa: E402


def _top(prof: cProfile.Profile, n_struct: int, top: int) -> list[dict[str, Any]]:
    """The ``top`` functions by own time: name, ms per structure, calls per structure."""
    st = pstats.Stats(prof)
    rows = []
    for (file, line, name), (_, ncalls, tottime, _, _) in st.stats.items():  # type: ignore[attr-defined]
        where = file.split("site-packages/")[-1] if "site-packages" in file else file.split("/")[-1]
        rows.append({"function": f"{where}:{line}({name})", "ms_per_structure": 1e3 * tottime / n_struct,
                     "calls_per_structure": ncalls / n_struct})
    rows.sort(key=lambda r: -r["ms_per_structure"])
    return [{k: (round(v, 3) if isinstance(v, float) else v) for k, v in r.items()} for r in rows[:top]]


def _case(run: Callable[[], Any], n: int, n_machs: int, eig_ms: float, top: int) -> dict[str, Any]:
    """CPU ms per structure (no profiler), solve counts and the profile of ``run`` (n structures)."""
    from romams_core.flutter import batch

    batch.STATS.reset()
    t0 = time.process_time()
    run()
    cpu = 1e3 * (time.process_time() - t0) / n
    stats = batch.STATS
    out = {"cpu_ms_per_structure": cpu, "eigen_solves_per_mach": stats.matrices / (n * n_machs),
           "lapack_eig_calls_per_structure": stats.eig_calls / n, "newton_roots_per_mach": stats.newton_roots / (
               n * n_machs), "eig_floor_ms_per_structure": stats.matrices / n * eig_ms}
    prof = cProfile.Profile(time.process_time)  # CPU time: the machine is shared
    prof.runcall(run)
    out["top"] = _top(prof, n, top)
    return out


def main() -> None:
    """Command line (module docstring)."""
    from benchmarks import run as bench
    from romams_core.basis import random_designs
    from romams_core.evaluate import evaluate_structure, evaluate_structures
    from romams_core.structure.modal import modal_analysis

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--solver", default="dlm", choices=["dlm", "uvlm"])
    ap.add_argument("--designs", type=int, default=30)
    ap.add_argument("--top", type=int, default=14)
    ap.add_argument("--tracking", choices=["eigen", "continuation"], default=None, help="branch tracker of the "
                    "flutter searches (default: the flutter default)")
    args = ap.parse_args()
    bench.SOLVER["name"] = args.solver
    models = bench.build_models(samples=25)
    wing, mesh, basis, roms = models["wing"], models["mesh"], models["basis"], models["roms"]
    zeta = wing.modal_damping or None
    designs = random_designs(wing, args.designs + 1, seed=1)
    kw: dict[str, Any] = dict(mac_threshold=basis.mac_threshold, zeta=zeta)
    if args.tracking is not None:
        kw["flutter_options"] = {"tracking": args.tracking}
    evaluate_structure(modal_analysis(wing, designs[0], 4, mesh), basis.shapes, roms, **kw)  # warm-up
    eig_ms = bench.eig_calibration_ms()

    def one() -> None:
        for x in designs[1:]:
            evaluate_structure(modal_analysis(wing, x, 4, mesh), basis.shapes, roms, **kw)

    def many() -> None:
        evaluate_structures([modal_analysis(wing, x, 4, mesh) for x in designs[1:]], basis.shapes, roms, **kw)

    def modal_only() -> None:
        for x in designs[1:]:
            modal_analysis(wing, x, 4, mesh)

    n, nm = args.designs, len(roms)
    t0 = time.process_time()
    modal_only()
    out = {"solver": args.solver, "tracking": args.tracking, "designs": n, "machs": sorted(roms),
           "eig_calibration_ms": eig_ms,
           "rom_states": [int(r.ss.A.shape[0]) for _, r in sorted(roms.items())],
           "modal_ms_per_structure": 1e3 * (time.process_time() - t0) / n,
           "alone": _case(one, n, nm, eig_ms, args.top), "batch": _case(many, n, nm, eig_ms, args.top)}
    print(json.dumps(out, indent=1, default=float))


if __name__ == "__main__":
    main()
