"""Speed of the flutter search and of a whole per-structure evaluation, printed as JSON.

Target (DESIGN.md section 4): one structure = modal analysis + flutter at 5 Machs <= 50 ms on one core.
Cases: (1) the Jones typical section (8 aero states), every sweep and coupling; (2) the cropped-delta
wing with a PCA basis and UVLM-trained ROMs (reduced by balanced truncation) at the 5 Machs of the
paper: flutter per Mach and the full evaluate_structure over random designs (modal + projection +
to_modal + 5 flutter searches + envelope), with modal damping zeta (default 0.01; see docs/flutter.md
for why zeta = 0 is degenerate with the UVLM ROMs). Case (2) trains the ROMs first (seconds per Mach).
Usage: python -m benchmarks.bench_flutter [--designs 20] [--zeta 0.01] [--no-uvlm]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core, before numpy loads its BLAS

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

from romams_core.flutter import flutter_analysis  # noqa: E402
from romams_core.typical_section import TypicalSection, jones_discrete, modes  # noqa: E402

MACHS = (0.79, 0.83, 0.87, 0.91, 0.95)


def _timeit(fn, repeat: int) -> tuple[float, Any]:
    """Median wall time (ms) of fn() over ``repeat`` calls, and the last result."""
    out = fn()
    ts = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        ts.append(time.perf_counter() - t0)
    return 1e3 * float(np.median(ts)), out


def typical_section(repeat: int = 20) -> dict[str, Any]:
    """Timings (ms) and U_F/(b w_alpha) of the Hodges & Pierce section for each sweep and coupling."""
    ts = TypicalSection()
    w, _ = modes(ts)
    ss = jones_discrete(ts, 0.05)
    out: dict[str, Any] = {"aero_states": int(ss.A.shape[0])}
    for coupling in ("tustin", "zoh"):
        ms, r = _timeit(lambda c=coupling: flutter_analysis(
            w, ss, ts.c_ref, 0.0, sweep="constant-density", coupling=c, rho_ref=ts.rho, v_max=100.0), repeat)
        uf = r.v_flutter_m_s / (ts.semichord_m * ts.omega_alpha)
        out[f"constant-density/{coupling}"] = {"ms": ms, "uf_b_walpha": uf}
        for sweep in ("constant-speed", "matched"):
            ms, r = _timeit(lambda s=sweep, c=coupling: flutter_analysis(w, ss, ts.c_ref, 0.3, sweep=s, coupling=c),
                            repeat)
            out[f"{sweep}/{coupling}"] = {"ms": ms, "q_flutter_pa": r.q_flutter_pa}
    return out


def cropped_delta(n_designs: int = 20, seed: int = 0, zeta: float = 0.01) -> dict[str, Any]:
    """Per-structure evaluation timings with UVLM ROMs at the paper's 5 Machs (cropped-delta template)."""
    from romams_core.aero.uvlm import UvlmSolver
    from romams_core.basis import build_basis_for_wing, project
    from romams_core.evaluate import evaluate_structure
    from romams_core.mesh import standard_mesh
    from romams_core.statespace import to_modal
    from romams_core.structure.modal import modal_analysis
    from romams_core.training import train_rom
    from romams_core.wing import template

    wing = template("cropped-delta")
    mesh = standard_mesh(wing.planform)
    t0 = time.perf_counter()
    basis = build_basis_for_wing(wing, samples=25, modes=4)
    shapes = basis.shapes[:, : basis.n_basis]
    t_basis = time.perf_counter() - t0
    roms, t_train, states = {}, {}, {}
    for mach in MACHS:
        t0 = time.perf_counter()
        roms[mach] = train_rom(mesh, shapes, mach, UvlmSolver(), reduce_order="auto")
        t_train[str(mach)] = time.perf_counter() - t0
        states[str(mach)] = int(roms[mach].ss.A.shape[0])
    base = modal_analysis(wing, None, n_modes=4, mesh=mesh)
    bench = evaluate_structure(base, shapes, roms, zeta=zeta).envelope
    per_mach = {}
    gamma = project(shapes, base.shapes).gamma
    for mach in MACHS:
        mss = to_modal(roms[mach].ss, gamma)
        for coupling in ("tustin", "zoh"):
            ms, r = _timeit(lambda m=mach, s=mss, c=coupling: flutter_analysis(
                base.omega, s, wing.planform.c_ref, m, coupling=c, zeta=zeta), 10)
            fine = flutter_analysis(base.omega, mss, wing.planform.c_ref, mach, coupling=coupling, zeta=zeta,
                                    n_points=48)  # tracking cross-check on a 4x finer coarse grid
            per_mach[f"{mach}/{coupling}"] = {
                "ms": ms, "flutter_found": r.flutter_found, "q_flutter_pa": r.q_flutter_pa,
                "v_flutter_m_s": r.v_flutter_m_s, "flutter_mode": r.flutter_mode, "sdoff": r.sdoff,
                "q_flutter_pa_48pts": fine.q_flutter_pa, "flutter_mode_48pts": fine.flutter_mode,
            }
    rng = np.random.default_rng(seed)
    b = wing.bounds()
    designs = b[:, 0] + rng.random((n_designs, b.shape[0])) * (b[:, 1] - b[:, 0])
    t_modal, t_eval, cpu = [], [], []
    ok = 0
    for d in designs:
        c0 = time.process_time()
        t0 = time.perf_counter()
        modal = modal_analysis(wing, d, n_modes=4, mesh=mesh)
        t1 = time.perf_counter()
        ev = evaluate_structure(modal, shapes, roms, benchmark=bench, zeta=zeta)
        t2 = time.perf_counter()
        cpu.append(time.process_time() - c0)
        t_modal.append(t1 - t0)
        t_eval.append(t2 - t1)
        ok += int(ev.constraints_ok)
    tot = 1e3 * (np.asarray(t_modal) + np.asarray(t_eval))
    return {
        "n_basis": int(basis.n_basis),
        "basis_s": t_basis,
        "train_s": t_train,
        "rom_states": states,
        "baseline_frequencies_hz": base.frequencies_hz.tolist(),
        "baseline_envelope_m": bench.safe_altitude_m.tolist(),
        "baseline_flutter": per_mach,
        "designs": int(n_designs),
        "designs_constraints_ok": ok,
        "modal_ms_median": 1e3 * float(np.median(t_modal)),
        "flutter5_ms_median": 1e3 * float(np.median(t_eval)),
        "structure_ms_median": float(np.median(tot)),
        "structure_ms_p90": float(np.percentile(tot, 90)),
        "structure_cpu_ms_median": 1e3 * float(np.median(cpu)),
        "zeta": zeta,
        "target_ms": 50.0,
    }


def main() -> None:
    """Run the benchmarks and print one JSON document."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--designs", type=int, default=20)
    ap.add_argument("--zeta", type=float, default=0.01, help="modal structural damping ratio")
    ap.add_argument("--no-uvlm", action="store_true", help="skip the cropped-delta UVLM case")
    args = ap.parse_args()
    out: dict[str, Any] = {"benchmark": "flutter", "typical_section": typical_section()}
    if not args.no_uvlm:
        out["cropped_delta"] = cropped_delta(args.designs, zeta=args.zeta)
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
