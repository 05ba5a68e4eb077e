"""The ROM-AMS paper's optimization (section 3.2) run remotely against a romams service.

Minimize the structural mass of the parameter-changeable cropped delta wing (7 design variables)
subject to the transonic flutter envelope: differential evolution with the paper's settings (F = 0.55,
CR = 0.7, Np = 30, 150 generations = 30 + 150 x 30 = 4530 structures), penalty objective
mass + mu * C(x) with C = 1 when the safe envelope is above the baseline plate's at any Mach, when any
Mach has single-degree-of-freedom flutter, or when a mode fits the basis with MAC < 0.98. One batch
request per generation (scipy's vectorized, deferred-updating DE; the initial population is a Latin
hypercube of Np points, so scipy's popsize multiplier is not used).

    romams serve &                      # or any running service
    python examples/optimize_cropped_delta.py --out de-out [--generations 150] [--popsize 30] [--seed 0]

The service is prepared when needed (wing, basis, ROMs at the five Mach numbers). At the end the
optimum is verified with ROM-PMS (models identified on the optimum's own modes): through the API's
method "rom-pms" if it offers one, else in process with romams_core when that is installed
(``--verify local``), the paper's Table 8. Writes summary.json and the figures of the paper's Fig. 15
(convergence), Fig. 16 (design variables / optimum) and Fig. 18 (envelope history).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from scipy.optimize import differential_evolution
from scipy.stats import qmc

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from a checkout
    sys.path.insert(0, str(ROOT))

from client import FlutterProblem, RomamsClient, RomamsError  # noqa: E402

PAPER_MACHS = (0.79, 0.83, 0.87, 0.91, 0.95)
#: DE settings of the paper (section 3.2)
PAPER_F, PAPER_CR, PAPER_NP, PAPER_GENERATIONS = 0.55, 0.7, 30, 150
#: the paper's results (Euler-based ROM-AMS; a linear aerodynamic solver will differ)
PAPER_OPTIMUM = {"x1": 0.1535, "x2": 0.6135, "x3": 0.8247, "x4": 0.0203, "x5": 1.966, "x6": 0.8787, "x7": 0.5972}
PAPER_MASS_KG, PAPER_BASELINE_MASS_KG = 0.1717, 0.24
PAPER_TABLE8 = {0.79: (302.08, 312.21), 0.83: (298.42, 307.06), 0.87: (297.02, 299.45), 0.91: (294.36, 288.32),
                0.95: (289.63, 277.62)}  # Mach: (ROM-AMS, ROM-PMS) flutter speed, m/s

Log = Callable[[str], None]


def log_stderr(msg: str) -> None:
    """Progress line on stderr."""
    print(msg, file=sys.stderr, flush=True)


# ---- service preparation ------------------------------------------------------------------------------
def prepare_service(client: RomamsClient, wing: str, machs: tuple[float, ...], samples: int, basis_seed: int,
                    train_options: dict[str, Any], log: Log = log_stderr, progress: bool = True,
                    basis_mac: float = 0.9999, max_basis: int = 8, solver: str = "dlm") -> int:
    """Wing id with a basis and ROMs at ``machs`` (created / trained when missing; an existing basis is reused)."""
    wid = client.ensure_wing(wing, "cropped-delta")
    info = client.get_wing(wid)
    if info.get("latest_basis_id") is None:
        log(f"wing {wing!r}: building the basis ({samples} LHS samples x 4 modes)")
        # MAC >= 0.9999 with at most 8 shapes, as in the paper: the flutter accuracy of ROM-AMS needs the
        # shapes' chordwise slopes fitted too, which the design default of 0.98 (5 shapes) does not ensure
        job = client.wait_job(client.start_basis(wid, samples=samples, modes=4, mac_threshold=basis_mac,
                                                 max_basis=max_basis, seed=basis_seed),
                              progress=progress, desc="basis")
        log(f"  basis {job['result']['basis_id']}: {job['result']['n_basis']} shapes, "
            f"worst sample MAC {job['result']['min_mac']:.4f}")
    t0 = time.perf_counter()
    roms = client.train(wid, list(machs), solver=solver, options=train_options, progress=progress)
    trained = ", ".join(f"{m:g}" for m in sorted({round(float(r["mach"]), 6) for r in roms}))  # distinct Machs
    log(f"ROMs at Mach {trained} ready ({time.perf_counter() - t0:.1f} s)")
    return wid


# ---- differential evolution ---------------------------------------------------------------------------
def lhs_population(problem: FlutterProblem, n: int, seed: int) -> np.ndarray:
    """Initial population: ``n`` Latin-hypercube points in the design bounds [n, d]."""
    return problem.denormalize(qmc.LatinHypercube(d=problem.dim, seed=seed).random(n))


def _generation_record(gen: int, pop: np.ndarray, energies: np.ndarray, seen: dict[bytes, dict[str, Any]],
                       t0: float, problem: FlutterProblem) -> dict[str, Any]:
    """Per-generation summary: best individual (objective, mass, feasibility, envelope), population spread."""
    i = int(np.argmin(energies))
    best = seen[pop[i].tobytes()]
    feas = np.array([seen[p.tobytes()]["feasible"] for p in pop])
    return {
        "generation": gen, "evaluations": problem.n_evaluations, "wall_s": time.perf_counter() - t0,
        "best_objective": float(energies[i]), "best_mass_kg": best["mass_kg"], "best_feasible": best["feasible"],
        "best_x": pop[i].tolist(), "best_safe_altitude_m": best["safe_altitude_m"],
        "best_v_flutter_m_s": best["v_flutter_m_s"], "n_feasible": int(feas.sum()),
        "mean_objective": float(np.mean(energies)),
        "population_std_normalized": np.std(problem.normalize(pop), axis=0).tolist(),
    }


def run_de(problem: FlutterProblem, generations: int = PAPER_GENERATIONS, popsize: int = PAPER_NP, seed: int = 0,
           mutation: float = PAPER_F, recombination: float = PAPER_CR, log: Log = log_stderr) -> dict[str, Any]:
    """DE/rand/1/bin with one batch request per generation; returns the result and per-generation history."""
    if popsize < 5:
        raise ValueError(f"popsize: DE needs at least 5 individuals, got {popsize}")
    if generations < 0:
        raise ValueError(f"generations: must be >= 0, got {generations}")
    seen: dict[bytes, dict[str, Any]] = {}  # every evaluated design -> its data
    history: list[dict[str, Any]] = []
    t0 = time.perf_counter()

    def objective(x: np.ndarray) -> np.ndarray:
        pop = np.atleast_2d(np.asarray(x, dtype=float).T)  # scipy passes [d, S]
        ev = problem.evaluate(pop)
        for k, p in enumerate(ev.x):
            seen[p.tobytes()] = {
                "mass_kg": None if not math.isfinite(ev.mass_kg[k]) else float(ev.mass_kg[k]),
                "feasible": bool(ev.feasible[k]), "objective": float(ev.objective[k]),
                "safe_altitude_m": [None if not math.isfinite(a) else float(a) for a in ev.safe_altitude_m[k]],
                "v_flutter_m_s": [None if not math.isfinite(v) else float(v) for v in ev.v_flutter_m_s[k]],
            }
        if not history:  # the initial population (generation 0)
            history.append(_generation_record(0, ev.x, ev.objective, seen, t0, problem))
            _report(history[-1], generations, log)
        return ev.objective

    def callback(intermediate_result: Any) -> bool:
        rec = _generation_record(int(intermediate_result.nit), np.asarray(intermediate_result.population),
                                 np.asarray(intermediate_result.population_energies), seen, t0, problem)
        history.append(rec)
        _report(rec, generations, log)
        return False

    init = lhs_population(problem, popsize, seed)
    res = differential_evolution(
        objective, problem.bounds, strategy="rand1bin", maxiter=generations, init=init, mutation=mutation,
        recombination=recombination, seed=seed, polish=False, tol=0.0, atol=0.0, updating="deferred",
        vectorized=True, callback=callback)
    best = seen[np.asarray(res.x, dtype=float).tobytes()]
    return {"x": np.asarray(res.x).tolist(), "objective": float(res.fun), "best": best,
            "nfev": int(problem.n_evaluations), "generations": int(res.nit), "message": str(res.message),
            "history": history, "wall_s": time.perf_counter() - t0, "batch_requests": problem.n_calls}


def _report(rec: dict[str, Any], generations: int, log: Log) -> None:
    """One progress line per generation."""
    mass = rec["best_mass_kg"]
    log(f"gen {rec['generation']:4d}/{generations}  best {rec['best_objective']:.5f} "
        f"({'feasible' if rec['best_feasible'] else 'INFEASIBLE'}, mass {mass if mass is None else round(mass, 5)} kg)"
        f"  feasible {rec['n_feasible']}  evals {rec['evaluations']}  {rec['wall_s']:.1f} s")


# ---- verification of the optimum ------------------------------------------------------------------------
def verify_api(client: RomamsClient, wing: int, x: list[float], machs: list[float]) -> dict[str, Any] | None:
    """ROM-PMS evaluation of ``x`` by the service (method "rom-pms"); None when the API does not offer it."""
    try:
        return client.evaluate(wing, x, machs=machs, method="rom-pms", store=True)
    except RomamsError as exc:
        if exc.status == 422 and (exc.field or "").startswith("method"):
            return None
        raise


def verify_local(definition: dict[str, Any], x: list[float], machs: list[float], n_modes: int,
                 train_options: dict[str, Any], mac_threshold: float = 0.98, solver: str = "dlm") -> dict[str, Any]:
    """ROM-PMS in process: ROMs of ``solver`` trained on the optimum's own modes (the service's training
    dispatch, romams.services.training), same flutter search."""
    from romams.services.training import rom_identity, train
    from romams_core.evaluate import evaluate_structure
    from romams_core.mesh import standard_mesh
    from romams_core.structure.modal import modal_analysis
    from romams_core.wing import WingDefinition

    wing = WingDefinition.from_dict(definition)
    mesh = standard_mesh(wing.planform)
    modal = modal_analysis(wing, np.asarray(x, dtype=float), n_modes=n_modes, mesh=mesh)
    t0 = time.perf_counter()
    ident = rom_identity(solver, options=train_options)
    roms = {float(m): train(mesh, modal.shapes, float(m), ident) for m in machs}
    ev = evaluate_structure(modal, modal.shapes, roms, mac_threshold=mac_threshold, zeta=wing.modal_damping or None)
    rows = [{"mach": float(r.mach), "v_flutter_m_s": r.v_flutter_m_s if r.flutter_found else None,
             "v_eas_m_s": r.v_eas_m_s if r.flutter_found else None,
             "omega_flutter_rad_s": r.omega_flutter_rad_s if r.flutter_found else None, "sdoff": bool(r.sdoff),
             "flutter_mode": r.flutter_mode} for r in ev.flutter]
    return {"method": "rom-pms (local, romams_core)", "mass_kg": float(ev.mass_kg), "results": rows,
            "seconds": time.perf_counter() - t0, "zeta": float(wing.modal_damping)}


def accuracy_table(ams: dict[str, Any], pms: dict[str, Any] | None) -> list[dict[str, Any]]:
    """Table 8: flutter speed (EAS) and frequency by ROM-AMS and ROM-PMS per Mach, with the relative error (%)."""
    by = {round(r["mach"], 6): r for r in (pms or {}).get("results", [])}
    rows = []
    for r in ams["results"]:
        p = by.get(round(r["mach"], 6), {})
        row = {"mach": r["mach"], "v_ams": r["v_eas_m_s"], "v_pms": p.get("v_eas_m_s"),
               "omega_ams": r["omega_flutter_rad_s"], "omega_pms": p.get("omega_flutter_rad_s")}
        for key, a, b in (("v_error_pct", row["v_ams"], row["v_pms"]),
                          ("omega_error_pct", row["omega_ams"], row["omega_pms"])):
            row[key] = None if a is None or b is None else 100.0 * (a - b) / b
        paper = PAPER_TABLE8.get(round(r["mach"], 2))
        row["paper_v_ams"], row["paper_v_pms"] = paper if paper else (None, None)
        rows.append(row)
    return rows


# ---- figures --------------------------------------------------------------------------------------------
def normalized_by_optimum(xs: np.ndarray, x_opt: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """x / x_opt (the paper's Fig. 16); where x_opt is ~0 (e.g. no lumped mass), 1 + (x - x_opt) / range."""
    tiny = np.abs(x_opt) < 1e-6 * (upper - lower)
    safe = np.where(tiny, 1.0, x_opt)
    return np.where(tiny, 1.0 + (xs - x_opt) / (upper - lower), xs / safe)


def write_figures(out: Path, run: dict[str, Any], names: list[str], lower: np.ndarray, upper: np.ndarray,
                  machs: list[float], baseline: dict[str, Any]) -> list[str]:
    """Fig. 15 (convergence), Fig. 16 (design variables / optimum), Fig. 18 (envelope history) as PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    hist = run["history"]
    gens = [h["generation"] for h in hist]
    files = []
    fig, ax = plt.subplots(figsize=(6, 4), layout="constrained")
    ax.plot(gens, [h["best_objective"] for h in hist], "k-", label="objective (mass + mu C)")
    masses = [h["best_mass_kg"] if h["best_feasible"] else np.nan for h in hist]
    ax.plot(gens, masses, "C0--", label="best feasible mass")
    ax.axhline(baseline["mass_kg"], color="C3", lw=0.8, ls=":", label=f"baseline {baseline['mass_kg']:.4f} kg")
    ax.set(xlabel="generation", ylabel="kg", title="Convergence of the structural mass (cf. paper Fig. 15)")
    if all(h["best_feasible"] for h in hist):
        ax.set_ylim(min(masses) * 0.95, max(max(masses), baseline["mass_kg"]) * 1.05)
    ax.legend()
    fig.savefig(out / "convergence.png", dpi=120)
    files.append("convergence.png")
    plt.close(fig)

    xs = np.array([h["best_x"] for h in hist])
    norm = normalized_by_optimum(xs, np.asarray(run["x"]), lower, upper)
    fig, ax = plt.subplots(figsize=(6, 4), layout="constrained")
    for j, name in enumerate(names):
        ax.plot(gens, norm[:, j], label=name)
    ax.axhline(1.0, color="k", lw=0.6)
    ax.set(xlabel="generation", ylabel="x / x_optimum", title="Design variables of the best individual (Fig. 16)")
    ax.legend(ncol=4, fontsize=8)
    fig.savefig(out / "design_history.png", dpi=120)
    files.append("design_history.png")
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(6, 4), layout="constrained")
    base_alt = [r["safe_altitude_m"] for r in baseline["results"]]
    ax.plot(machs, np.array(base_alt, dtype=float) / 1e3, "k-o", lw=2, label="benchmark (baseline plate)")
    last = gens[-1]
    picks = sorted({0, min(50, last), last} | ({last // 2} if last > 100 else set()))
    for g in picks:
        h = hist[gens.index(g)]
        ax.plot(machs, np.array(h["best_safe_altitude_m"], dtype=float) / 1e3, "--s", label=f"G{g} best")
    ax.set(xlabel="Mach", ylabel="lowest safe altitude, km", title="Flutter envelope history (cf. paper Fig. 18)")
    ax.legend()
    fig.savefig(out / "envelope_history.png", dpi=120)
    files.append("envelope_history.png")
    plt.close(fig)
    return files


# ---- main -------------------------------------------------------------------------------------------------
def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Command-line entry point; returns the summary (also written to OUT/summary.json)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--url", default="http://127.0.0.1:8000", help="service base URL")
    ap.add_argument("--api-key", default=None, help="Bearer key when the service requires one")
    ap.add_argument("--wing", default="cropped-delta", help="wing name on the service (created from the template)")
    ap.add_argument("--generations", type=int, default=PAPER_GENERATIONS)
    ap.add_argument("--popsize", type=int, default=PAPER_NP, help="population size Np (not scipy's multiplier)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--mu", type=float, default=10.0, help="penalty factor, kg")
    ap.add_argument("--penalty", choices=("binary", "graded"), default="binary",
                    help="C(x): 1 for any violation (the paper), or 1 + the size of the violations")
    ap.add_argument("--envelope-tol", type=float, default=0.01, help="altitude tolerance of the envelope check, m")
    ap.add_argument("--machs", type=float, nargs="+", default=list(PAPER_MACHS))
    ap.add_argument("--samples", type=int, default=25, help="LHS samples if the basis must be built")
    ap.add_argument("--solver", choices=("dlm", "uvlm"), default="dlm",
                    help="aerodynamic solver of the ROMs (dlm: doublet lattice, the service default)")
    ap.add_argument("--train-options", default=None,
                    help="JSON of extra training settings if ROMs must be trained (default: none for dlm, "
                         '{"reduce_order": "auto"} for uvlm)')
    ap.add_argument("--verify", choices=("auto", "api", "local", "none"), default="auto",
                    help="ROM-PMS check of the optimum: the API's method, in-process romams_core, or both (auto)")
    ap.add_argument("--out", type=Path, default=Path("de-out"))
    ap.add_argument("--quiet", action="store_true", help="no progress bars")
    args = ap.parse_args(argv)
    default_options = '{"reduce_order": "auto"}' if args.solver == "uvlm" else "{}"
    try:
        train_options = json.loads(args.train_options if args.train_options is not None else default_options)
    except json.JSONDecodeError as exc:
        ap.error(f"--train-options: not JSON ({exc})")
    machs = tuple(sorted(args.machs))
    args.out.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()
    with RomamsClient(args.url, api_key=args.api_key) as client:
        wid = prepare_service(client, args.wing, machs, args.samples, 0, train_options, progress=not args.quiet,
                              solver=args.solver)
        t_ready = time.perf_counter()
        problem = FlutterProblem(client, wid, machs=machs, mu=args.mu, keep_history=False, penalty=args.penalty,
                                 envelope_tol_m=args.envelope_tol)
        baseline = problem.baseline()
        log_stderr(f"baseline: mass {baseline['mass_kg']:.4f} kg, safe altitudes "
                   + ", ".join(f"M{r['mach']:g}: {r['safe_altitude_m']:.0f} m" for r in baseline["results"]))
        log_stderr(f"DE: Np = {args.popsize}, F = {PAPER_F}, CR = {PAPER_CR}, {args.generations} generations "
                   f"({args.popsize * (args.generations + 1)} structures)")
        run = run_de(problem, args.generations, args.popsize, args.seed)
        x_opt = run["x"]
        optimum = client.evaluate(wid, x_opt, machs=list(machs), store=True)
        pms, pms_note = None, ""
        if args.verify in ("auto", "api"):
            pms = verify_api(client, wid, x_opt, list(machs))
            pms_note = "service method rom-pms" if pms else "the API offers no 'rom-pms' method"
        if pms is None and args.verify in ("auto", "local"):
            try:
                definition = client.get_wing(wid)["definition"]
                pms = verify_local(definition, x_opt, list(machs), len(optimum["frequencies_hz"]), train_options,
                                   solver=args.solver)
                pms_note += ("; " if pms_note else "") + "verified in process with romams_core"
            except ImportError:
                pms_note += "; romams_core is not installed here, no ROM-PMS verification"
        names, lower, upper = problem.names, problem.lower, problem.upper
        figures = write_figures(args.out, run, names, lower, upper, list(machs), baseline)
    mass0 = float(baseline["mass_kg"])
    mass = float(optimum["mass_kg"])
    summary = {
        "url": args.url, "wing_id": wid, "machs": list(machs),
        "settings": {"F": PAPER_F, "CR": PAPER_CR, "Np": args.popsize, "generations": args.generations,
                     "strategy": "rand1bin", "init": "latin hypercube", "mu_kg": args.mu, "seed": args.seed,
                     "penalty": args.penalty, "envelope_tol_m": args.envelope_tol},
        "optimum": dict(zip(names, x_opt, strict=True)), "optimum_mass_kg": mass,
        "optimum_feasible": bool(run["best"]["feasible"]),
        "baseline_mass_kg": mass0, "mass_reduction_pct": 100.0 * (mass0 - mass) / mass0,
        "paper": {"optimum": PAPER_OPTIMUM, "mass_kg": PAPER_MASS_KG,
                  "mass_reduction_pct": 100 * (PAPER_BASELINE_MASS_KG - PAPER_MASS_KG) / PAPER_BASELINE_MASS_KG},
        "envelope": [{"mach": r["mach"], "safe_altitude_m": r["safe_altitude_m"],
                      "benchmark_safe_altitude_m": b["safe_altitude_m"], "v_flutter_m_s": r["v_flutter_m_s"],
                      "omega_flutter_rad_s": r["omega_flutter_rad_s"], "sdoff": r["sdoff"]}
                     for r, b in zip(optimum["results"], baseline["results"], strict=True)],
        "mac": optimum["mac"], "frequencies_hz": optimum["frequencies_hz"],
        "verification": {"note": pms_note, "rom_pms": pms, "table8": accuracy_table(optimum, pms)},
        "evaluations": run["nfev"], "batch_requests": run["batch_requests"], "generations_run": run["generations"],
        "setup_s": t_ready - t_start, "optimization_s": run["wall_s"], "total_s": time.perf_counter() - t_start,
        "history": run["history"], "figures": figures,
    }
    (args.out / "summary.json").write_text(json.dumps(summary, indent=1))
    _print_result(summary)
    return summary


def _print_result(s: dict[str, Any]) -> None:
    """Human-readable end report on stdout (progress lines and logs go to stderr)."""
    print(f"optimum ({'feasible' if s['optimum_feasible'] else 'INFEASIBLE'}): "
          + ", ".join(f"{k} = {v:.4g}" for k, v in s["optimum"].items()))
    print(f"mass {s['optimum_mass_kg']:.4f} kg vs baseline {s['baseline_mass_kg']:.4f} kg: "
          f"{-s['mass_reduction_pct']:+.2f} % (paper: {-s['paper']['mass_reduction_pct']:+.2f} %)")
    print(f"{s['evaluations']} structures in {s['batch_requests']} batch requests, "
          f"{s['optimization_s']:.1f} s wall (setup {s['setup_s']:.1f} s)")
    print(f"verification: {s['verification']['note'] or 'none (--verify none)'}")
    print(" Mach  h_safe(m) bench(m)  V_AMS    V_PMS   err%   w_AMS   w_PMS   err%")

    def f(v: Any, fmt: str) -> str:
        return format(v, fmt) if v is not None else "-".rjust(len(format(0.0, fmt)))
    for e, t in zip(s["envelope"], s["verification"]["table8"], strict=True):
        print(f" {e['mach']:.2f} {f(e['safe_altitude_m'], '9.0f')} {f(e['benchmark_safe_altitude_m'], '8.0f')} "
              f"{f(t['v_ams'], '7.2f')} {f(t['v_pms'], '7.2f')} {f(t['v_error_pct'], '6.2f')} "
              f"{f(t['omega_ams'], '7.1f')} {f(t['omega_pms'], '7.1f')} {f(t['omega_error_pct'], '6.2f')}")


if __name__ == "__main__":
    main()
