"""Safe-envelope figure: designs against the benchmark (the constraint line), shaded pass / fail by margin.

The envelope check (``romams_core.envelope.compare_envelopes``) passes a design at a Mach number when its lowest
safe altitude (q <= q_f / margin^2) is not above the benchmark's (+ ``ENVELOPE_TOL_M``): the benchmark's safe
altitude is the constraint line. Below it is the pass side (green), above it the fail side (red); each design
point is green or red by the check's own per-Mach verdict, so the colours always match ``envelope_ok``. The
benchmark comes as an Envelope, or is rebuilt from a stored comparison (benchmark altitude = design + margin_m).
Without any benchmark (a wing without a baseline), the line drawn is the design's flutter boundary q = q_f,
whose distance to the safe altitude is the speed margin of the check.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from romams_core.envelope import Envelope, EnvelopeComparison, compare_envelopes, safe_envelope
from romams_core.errors import InputError

PASS_COLOR = "tab:green"
FAIL_COLOR = "tab:red"
BENCHMARK_LABEL = "benchmark (constraint line)"
FLUTTER_BOUNDARY_LABEL = "flutter boundary q = q_f (no benchmark)"


def _items(envelopes: Mapping[str, Any] | Sequence[Any]) -> list[tuple[str, Envelope]]:
    """(name, Envelope) pairs of a mapping or a list."""
    if isinstance(envelopes, Mapping):
        return list(envelopes.items())
    return [(f"design {i + 1}", e) for i, e in enumerate(envelopes)]


def benchmark_altitude(design: Envelope, comparison: EnvelopeComparison) -> np.ndarray:
    """The benchmark's safe altitude (m) per Mach, rebuilt from a design and its comparison (margin_m)."""
    return np.asarray(design.safe_altitude_m, float) + np.asarray(comparison.margin_m, float)


def _verdicts(items: list[tuple[str, Envelope]], benchmark: Envelope | None,
              comparisons: Mapping[str, EnvelopeComparison]) -> dict[str, EnvelopeComparison | None]:
    """Per design its comparison: the one given, else compare_envelopes against the benchmark, else None."""
    out: dict[str, EnvelopeComparison | None] = {}
    for name, env in items:
        out[name] = comparisons.get(name)
        if out[name] is None and benchmark is not None:
            try:
                out[name] = compare_envelopes(env, benchmark)
            except InputError:  # other Mach numbers than the benchmark's: drawn, not judged
                out[name] = None
    return out


def _shade(ax: Axes, mach: np.ndarray, h_km: np.ndarray, lo: float, hi: float, pad: float) -> None:
    """Pass side (below the constraint line, green) and fail side (above, red) across the plotted Mach range."""
    order = np.argsort(mach)
    m = np.concatenate([[mach[order][0] - pad], mach[order], [mach[order][-1] + pad]])
    h = np.concatenate([[h_km[order][0]], h_km[order], [h_km[order][-1]]])
    ax.fill_between(m, lo, h, color=PASS_COLOR, alpha=0.12, lw=0, label="pass side: safe altitude <= benchmark")
    ax.fill_between(m, h, hi, color=FAIL_COLOR, alpha=0.10, lw=0, label="fail side: safe altitude > benchmark")


def _constraint(items: list[tuple[str, Envelope]], benchmark: Envelope | None,
                verdicts: Mapping[str, EnvelopeComparison | None]) -> tuple[np.ndarray, np.ndarray, str] | None:
    """(Mach, altitude km, label) of the line to draw: the benchmark, else the flutter boundary of the first
    design (no benchmark at all); None when neither exists."""
    if benchmark is not None:
        return np.asarray(benchmark.mach, float), np.asarray(benchmark.safe_altitude_m, float) / 1e3, BENCHMARK_LABEL
    for name, env in items:
        comp = verdicts[name]
        if comp is not None:
            return np.asarray(env.mach, float), benchmark_altitude(env, comp) / 1e3, BENCHMARK_LABEL
    if items and np.size(items[0][1].mach):
        env = items[0][1]
        edge = safe_envelope(env.mach, env.q_flutter_pa, 1.0, tuple(env.altitude_range_m))
        return np.asarray(edge.mach, float), np.asarray(edge.safe_altitude_m, float) / 1e3, FLUTTER_BOUNDARY_LABEL
    return None


STATUS_NOTES = {"unsafe-in-range": "unsafe in the whole range", "safe-everywhere": "safe in the whole range"}


def _note_clamped(ax: Axes, mach: np.ndarray, h_km: np.ndarray, status: Sequence[str]) -> None:
    """Label the points whose safe altitude is clamped to the end of the altitude range."""
    for m, h, st in zip(mach, h_km, status, strict=True):
        if st in STATUS_NOTES:
            ax.annotate(STATUS_NOTES[st], (m, h), textcoords="offset points", xytext=(4, 6), fontsize=6)


def _limits(curves: list[np.ndarray]) -> tuple[float, float]:
    """Autoscaled altitude limits (km) of the finite values of all curves, padded by 8 % (at least 0.2 km)."""
    vals = np.concatenate([np.asarray(c, float).ravel() for c in curves]) if curves else np.zeros(1)
    vals = vals[np.isfinite(vals)]
    lo, hi = (float(vals.min()), float(vals.max())) if vals.size else (0.0, 1.0)
    pad = max(0.08 * (hi - lo), 0.2)
    return lo - pad, hi + pad


def envelope_figure(
    envelopes: Mapping[str, Any] | Sequence[Any],
    benchmark: Any | None = None,
    title: str = "Safe flight envelope (lowest safe altitude)",
    comparisons: Mapping[str, EnvelopeComparison] | None = None,
) -> Figure:
    """Lowest safe altitude vs Mach of designs (name -> Envelope, or a list) against the benchmark (an Envelope,
    or rebuilt from ``comparisons``: name -> EnvelopeComparison), pass/fail shaded, design points coloured by the
    envelope check's per-Mach verdict; the altitude axis autoscaled to the data."""
    items = _items(envelopes)
    if not items and benchmark is None:
        raise ValueError("envelopes: nothing to plot")
    verdicts = _verdicts(items, benchmark, dict(comparisons or {}))
    line = _constraint(items, benchmark, verdicts)
    curves = [np.asarray(e.safe_altitude_m, float) / 1e3 for _, e in items] + ([line[1]] if line else [])
    lo, hi = _limits(curves)
    machs = np.concatenate([np.asarray(e.mach, float) for _, e in items] + ([line[0]] if line else []))
    pad = max(0.05 * float(np.ptp(machs)), 0.02) if machs.size else 0.02
    fig = Figure(figsize=(7.0, 4.8), layout="constrained")
    ax = fig.subplots()
    if line is not None:
        if line[2] == BENCHMARK_LABEL:
            _shade(ax, line[0], line[1], lo, hi, pad)
        ax.plot(line[0], line[1], "k-o", lw=2, ms=4, label=line[2])
    oks = []
    for name, env in items:
        comp = verdicts[name]
        m, h = np.asarray(env.mach, float), np.asarray(env.safe_altitude_m, float) / 1e3
        if comp is None:
            ax.plot(m, h, "--s", lw=1.2, label=f"{name}: safe altitude (not judged: no benchmark)")
            _note_clamped(ax, m, h, env.status)
            continue
        ax.plot(m, h, "--", lw=1.2, label=f"{name}: envelope_ok = {comp.envelope_ok}")
        _note_clamped(ax, m, h, env.status)
        colors = [PASS_COLOR if ok else FAIL_COLOR for ok in comp.ok]  # the check's own per-Mach verdict
        ax.scatter(m, h, c=colors, marker="s", s=40, zorder=3, edgecolors="k", linewidths=0.5, gid=f"verdict:{name}")
        oks.append(comp.envelope_ok)
    if machs.size:
        ax.set_xlim(float(machs.min()) - pad, float(machs.max()) + pad)
    ax.set_ylim(lo, hi)
    ax.set_xlabel("Mach number")
    margin = items[0][1].margin if items else benchmark.margin
    ax.set_ylabel(f"lowest safe altitude (km), q <= q_f / {margin:g}^2")
    verdict = "" if len(oks) != 1 else ("  -- PASS" if oks[0] else "  -- FAIL")
    ax.set_title(title + verdict, fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=7)
    return fig
