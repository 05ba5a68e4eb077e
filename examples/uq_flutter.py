"""Monte Carlo uncertainty of the flutter speed of one design under design-variable scatter, over HTTP.

Each design variable is normal around its nominal value with a given relative standard deviation
(relative to the nominal value; to the variable's range where the nominal value is 0), clipped to the
variable's bounds. The samples go through the service's batch endpoint (one request per --batch
designs; large batches run as jobs that the client waits for). Output: per Mach the flutter-speed
mean, standard deviation and percentiles, the safe-altitude percentiles, the mass statistics and the
probability that the design violates the flutter constraints (JSON), and histograms (PNG).

    python examples/uq_flutter.py --out uq-out [--samples 10000] [--rel-std 0.02] [--rel-std-var x4=0.05]
           [--design x1=0.15,x2=0.61,...  |  --design-json de-out/summary.json]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from a checkout
    sys.path.insert(0, str(ROOT))

from client import FlutterProblem, RomamsClient  # noqa: E402

PAPER_OPTIMUM = {"x1": 0.1535, "x2": 0.6135, "x3": 0.8247, "x4": 0.0203, "x5": 1.966, "x6": 0.8787, "x7": 0.5972}
# the default nominal design: feasible in this model with margin at every Mach (docs/optimization.md, section 4);
# the paper's optimum is not (its safe envelope lies 5.9-7.0 km above the benchmark's here)
DEFAULT_DESIGN = {"x1": 0.61, "x2": 0.158, "x3": 0.78, "x4": 0.042, "x5": 1.249, "x6": 0.798, "x7": 0.965}
PERCENTILES = (1, 5, 25, 50, 75, 95, 99)
CAP_WARN_FRACTION = 0.05  # warn when more than this fraction of the samples sits at a cap at some Mach


def log(msg: str) -> None:
    """A progress or warning line on stderr (results go to stdout)."""
    print(msg, file=sys.stderr, flush=True)


def cap_warnings(machs: np.ndarray, status: np.ndarray, found: np.ndarray) -> list[str]:
    """Warnings for the Machs where more than CAP_WARN_FRACTION of the samples [n, n_mach] sit at a sweep cap:
    no flutter inside the speed sweep, or a safe altitude at the bottom / top of the searched altitude range."""
    out = []
    for j, m in enumerate(machs):
        no_flutter = float(np.mean(~found[:, j]))
        bottom = float(np.mean(status[:, j] == "safe-everywhere"))
        top = float(np.mean(status[:, j] == "unsafe-in-range"))
        parts = [f"{100 * no_flutter:.1f} % without flutter in the speed sweep" if no_flutter > CAP_WARN_FRACTION
                 else "",
                 f"{100 * bottom:.1f} % at the bottom of the altitude range (safe everywhere)"
                 if bottom > CAP_WARN_FRACTION else "",
                 f"{100 * top:.1f} % at the top of the altitude range (unsafe everywhere)" if top > CAP_WARN_FRACTION
                 else ""]
        parts = [p for p in parts if p]
        if parts:
            out.append(f"WARNING: M {m:.2f}: {'; '.join(parts)}: these values sit at a sweep cap, the statistics "
                       "there describe the cap, not the design")
    return out


def scatter_samples(nominal: np.ndarray, rel_std: np.ndarray, lower: np.ndarray, upper: np.ndarray, n: int,
                    seed: int) -> tuple[np.ndarray, np.ndarray]:
    """n designs [n, d]: normal about ``nominal`` with sigma = rel_std * |nominal| (rel_std * range where
    the nominal is 0), clipped to [lower, upper]. Returns (samples, sigma [d])."""
    nominal, rel_std = np.asarray(nominal, dtype=float), np.asarray(rel_std, dtype=float)
    if np.any(rel_std < 0) or not np.all(np.isfinite(rel_std)):
        raise ValueError("rel_std: relative standard deviations must be finite and >= 0")
    if np.any(nominal < lower) or np.any(nominal > upper):
        raise ValueError("design: the nominal design is outside the variable bounds")
    if n < 1:
        raise ValueError(f"samples: must be >= 1, got {n}")
    scale = np.where(np.abs(nominal) > 1e-12 * (upper - lower), np.abs(nominal), upper - lower)
    sigma = rel_std * scale
    x = nominal + sigma * np.random.default_rng(seed).standard_normal((n, nominal.size))
    return np.clip(x, lower, upper), sigma


def _stats(v: np.ndarray) -> dict[str, Any]:
    """Mean, std and percentiles of the finite values of v, and their count."""
    f = v[np.isfinite(v)]
    if f.size == 0:
        return {"n": 0}
    return {"n": int(f.size), "mean": float(f.mean()), "std": float(f.std(ddof=1)) if f.size > 1 else 0.0,
            "min": float(f.min()), "max": float(f.max()),
            "percentiles": {str(p): float(q) for p, q in zip(PERCENTILES, np.percentile(f, PERCENTILES), strict=True)}}


def parse_pairs(text: str | None, names: list[str], what: str) -> dict[str, float]:
    """'x1=0.1,x4=0.02' -> {name: value}; ValueError naming an unknown variable or a bad number."""
    out: dict[str, float] = {}
    for item in filter(None, (t.strip() for t in (text or "").split(","))):
        key, sep, val = item.partition("=")
        if not sep or key.strip() not in names:
            raise ValueError(f"{what}: expected NAME=VALUE with NAME in {names}, got {item!r}")
        try:
            out[key.strip()] = float(val)
        except ValueError:
            raise ValueError(f"{what}: {key.strip()}: not a number: {val!r}") from None
    return out


def write_histograms(path: Path, machs: np.ndarray, vf: np.ndarray, alt: np.ndarray, nominal_vf: np.ndarray,
                     nominal_alt: np.ndarray, bench_alt: np.ndarray | None) -> None:
    """Flutter speed and safe altitude histograms, one column per Mach, with the 5/95 % percentiles."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    k = machs.size
    fig, axes = plt.subplots(2, k, figsize=(2.9 * k, 5.4), layout="constrained", squeeze=False)
    for j in range(k):
        for row, (data, nom, label) in enumerate(((vf[:, j], nominal_vf[j], "flutter speed (EAS), m/s"),
                                                  (alt[:, j] / 1e3, nominal_alt[j] / 1e3, "safe altitude, km"))):
            ax = axes[row, j]
            d = data[np.isfinite(data)]
            if d.size:
                ax.hist(d, bins=40, color="C0", alpha=0.8)
                for q in np.percentile(d, (5, 95)):
                    ax.axvline(q, color="C1", ls="--", lw=0.9)
            if math.isfinite(nom):
                ax.axvline(nom, color="k", lw=1.2, label="nominal")
            if row == 1 and bench_alt is not None and math.isfinite(bench_alt[j]):
                ax.axvline(bench_alt[j] / 1e3, color="C3", lw=1.2, label="benchmark")
            ax.set_xlabel(label, fontsize=8)
            if row == 0:
                ax.set_title(f"M = {machs[j]:g} ({d.size} with flutter)", fontsize=9)
        axes[1, j].legend(fontsize=7)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def report_lines(s: dict[str, Any]) -> list[str]:
    """The result table printed on stdout: nominal design, mass, P(violated), per-Mach flutter speed statistics."""
    nominal = ", ".join(f"{k} = {v:.4g}" for k, v in s["nominal"].items())
    nr = s["nominal_result"]
    m = s["mass_kg"]
    lines = [f"nominal design: {nominal} ({'feasible' if nr['feasible'] else 'INFEASIBLE'}, mass "
             f"{nr['mass_kg']:.4g} kg)",
             f"{s['samples']} samples, {s['wall_s']:.1f} s wall ({s['designs_per_s']:.1f} designs/s, "
             f"{s['batch_requests']} batch requests)",
             f"mass: mean {m.get('mean', math.nan):.4g} kg, std {m.get('std', math.nan):.3g} kg",
             f"P(constraint violated) = {s['probability_constraint_violated']:.3f}",
             f"{'Mach':>5} {'V_f mean':>9} {'std':>7} {'5 %':>8} {'95 %':>8} {'h_safe 50 %':>12} {'bench':>8} "
             f"{'no flutter':>10} {'at cap':>7}",
             f"{'':>5} {'m/s EAS':>9} {'m/s':>7} {'m/s':>8} {'m/s':>8} {'m':>12} {'m':>8} {'%':>10} {'%':>7}"]
    for row, bench in zip(s["per_mach"], s["benchmark_safe_altitude_m"], strict=True):
        v, h = row["v_eas_m_s"], row["safe_altitude_m"]
        vp = v.get("percentiles", {})
        lines.append(f"{row['mach']:5.2f} {v.get('mean', math.nan):9.1f} {v.get('std', math.nan):7.2f} "
                     f"{vp.get('5', math.nan):8.1f} {vp.get('95', math.nan):8.1f} "
                     f"{h.get('percentiles', {}).get('50', math.nan):12.0f} {bench:8.0f} "
                     f"{100 * row['no_flutter_fraction']:10.1f} {100 * row['at_cap_fraction']:7.1f}")
    return lines


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Command-line entry point; returns the summary (also written to OUT/uq_summary.json)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--url", default="http://127.0.0.1:8000")
    ap.add_argument("--api-key", default=None)
    ap.add_argument("--wing", default="cropped-delta", help="wing name or id on the service (with trained ROMs)")
    ap.add_argument("--design", default=None, help="nominal design NAME=VALUE,... (default: DEFAULT_DESIGN, "
                    "feasible in this model; --design paper takes the paper's optimum, infeasible here)")
    ap.add_argument("--design-json", type=Path, default=None, help="take the nominal design from the 'optimum' of a "
                    "summary.json written by optimize_cropped_delta.py")
    ap.add_argument("--rel-std", type=float, default=0.02, help="relative standard deviation of every variable")
    ap.add_argument("--rel-std-var", default=None, help="per-variable relative std NAME=VALUE,... (overrides)")
    ap.add_argument("--samples", type=int, default=10_000)
    ap.add_argument("--batch", type=int, default=2000, help="designs per batch request")
    ap.add_argument("--machs", type=float, nargs="+", default=None, help="default: every trained Mach")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=Path("uq-out"))
    ap.add_argument("--quiet", action="store_true")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    with RomamsClient(args.url, api_key=args.api_key) as client:
        problem = FlutterProblem(client, args.wing, machs=args.machs, keep_history=False)
        names = problem.names
        if args.design_json is not None:
            nominal_map = json.loads(args.design_json.read_text())["optimum"]
        elif args.design == "paper":
            nominal_map = PAPER_OPTIMUM
        elif args.design:
            nominal_map = parse_pairs(args.design, names, "--design")
        else:
            nominal_map = DEFAULT_DESIGN
        missing = [n for n in names if n not in nominal_map]
        if missing:
            ap.error(f"--design: missing variable(s) {missing}")
        nominal = np.array([float(nominal_map[n]) for n in names])
        rel = np.full(len(names), float(args.rel_std))
        for n, v in parse_pairs(args.rel_std_var, names, "--rel-std-var").items():
            rel[names.index(n)] = v
        x, sigma = scatter_samples(nominal, rel, problem.lower, problem.upper, args.samples, args.seed)
        nom = problem.evaluate(nominal[None, :])
        baseline = problem.baseline()
        parts = []
        bar = None
        if not args.quiet:
            from tqdm import tqdm

            bar = tqdm(total=len(x), unit="design", desc="Monte Carlo")
        for start in range(0, len(x), args.batch):
            parts.append(problem.evaluate(x[start:start + args.batch]))
            if bar is not None:
                bar.update(len(parts[-1].x))
        if bar is not None:
            bar.close()
    wall = time.perf_counter() - t0
    vf = np.vstack([p.v_eas_m_s for p in parts])  # EAS: the flutter speed that varies on a constant-speed sweep
    alt = np.vstack([p.safe_altitude_m for p in parts])
    mass = np.concatenate([p.mass_kg for p in parts])
    feasible = np.concatenate([p.feasible for p in parts])
    errors = sum(e is not None for p in parts for e in p.errors)
    machs = problem.machs
    status = np.vstack([p.envelope_status for p in parts])
    found = np.vstack([p.flutter_found for p in parts])
    cap = np.vstack([p.at_cap() for p in parts]) | ~found
    warnings = cap_warnings(machs, status, found)
    if not nom.feasible[0]:
        warnings.insert(0, "WARNING: the nominal design itself violates the flutter constraints in this model "
                           f"(envelope margins {np.round(nom.envelope_margin_m[0], 1).tolist()} m, min MAC "
                           f"{nom.min_mac[0]:.4f}, SDOFF {bool(nom.sdoff[0])}): P(violated) describes an infeasible "
                           "design")
    bench = np.array([r["safe_altitude_m"] for r in baseline["results"]], dtype=float)
    summary = {
        "url": args.url, "wing": args.wing, "machs": machs.tolist(), "samples": int(len(x)), "seed": args.seed,
        "nominal": dict(zip(names, nominal.tolist(), strict=True)),
        "sigma": dict(zip(names, sigma.tolist(), strict=True)),
        "relative_std": dict(zip(names, rel.tolist(), strict=True)),
        "nominal_result": {"mass_kg": float(nom.mass_kg[0]), "feasible": bool(nom.feasible[0]),
                           "v_eas_m_s": [None if not math.isfinite(v) else float(v) for v in nom.v_eas_m_s[0]],
                           "safe_altitude_m": nom.safe_altitude_m[0].tolist(),
                           "envelope_margin_m": nom.envelope_margin_m[0].tolist()},
        "benchmark_safe_altitude_m": bench.tolist(),
        "mass_kg": _stats(mass),
        "per_mach": [{"mach": float(m), "v_eas_m_s": _stats(vf[:, j]), "safe_altitude_m": _stats(alt[:, j]),
                      "no_flutter_fraction": float(np.mean(~np.isfinite(vf[:, j]))),
                      "at_cap_fraction": float(np.mean(cap[:, j]))}
                     for j, m in enumerate(machs)],
        "probability_constraint_violated": float(1.0 - feasible.mean()),
        "designs_rejected": int(errors),
        "wall_s": wall, "designs_per_s": len(x) / wall, "batch_requests": problem.n_calls,
        "figure": "uq_flutter.png", "warnings": warnings,
    }
    write_histograms(args.out / "uq_flutter.png", machs, vf, alt, nom.v_eas_m_s[0], nom.safe_altitude_m[0], bench)
    (args.out / "uq_summary.json").write_text(json.dumps(summary, indent=1))
    for w in warnings:
        log(w)
    for line in report_lines(summary):
        print(line)
    return summary


if __name__ == "__main__":
    main()
