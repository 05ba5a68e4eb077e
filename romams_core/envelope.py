"""Safe flight envelope from flutter dynamic pressures, and comparison of a design with a benchmark.

At each Mach number the safe dynamic pressure is q_safe = q_f / margin^2 (margin 1.15 = 15 % on speed,
i.e. 75.6 % of q_f), and the lowest safe altitude is the h where 0.5 rho(h) (M a(h))^2 = q_safe (ISA,
via romams_core.atmosphere): below it q > q_safe. Altitudes are searched in ``altitude_range_m``:
a Mach without flutter (q_f = inf) or with q_safe above q at the bottom of the range is safe at all
altitudes in range (status "safe-everywhere", altitude = range bottom); one with q_safe below q at the
top is "unsafe-in-range" (altitude = range top). The optimization constraint is that a design's safe
altitude is not above the benchmark's (the baseline structure's) at any Mach.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from romams_core.atmosphere import altitude_for_dynamic_pressure, flight_dynamic_pressure
from romams_core.errors import InputError

DEFAULT_MARGIN = 1.15
DEFAULT_ALTITUDE_RANGE_M = (0.0, 20_000.0)


@dataclass
class Envelope:
    """Safe envelope: per Mach q_f, q_safe (Pa), lowest safe altitude (m) and status."""

    mach: np.ndarray  # [n]
    q_flutter_pa: np.ndarray  # [n], inf where no flutter was found
    q_safe_pa: np.ndarray  # [n] q_f / margin^2
    safe_altitude_m: np.ndarray  # [n]
    status: list[str]  # "ok" | "safe-everywhere" | "unsafe-in-range"
    margin: float
    altitude_range_m: np.ndarray  # [2]


@dataclass
class EnvelopeComparison:
    """Design vs benchmark envelope per Mach: ok flags and margins (positive = design is safer)."""

    mach: np.ndarray  # [n]
    ok: list[bool]
    margin_m: np.ndarray  # [n] benchmark safe altitude - design safe altitude (m)
    margin_q_pct: np.ndarray  # [n] (q_safe design / q_safe benchmark - 1) * 100 (inf if design has no flutter)
    envelope_ok: bool


def _as_machs(mach: Any) -> np.ndarray:
    """Validated 1-D array of Mach numbers (> 0)."""
    m = np.atleast_1d(np.asarray(mach, dtype=float))
    if m.ndim != 1 or m.size == 0 or not np.all(np.isfinite(m)) or np.any(m <= 0):
        raise InputError("mach", f"must be a non-empty 1-D array of finite Mach numbers > 0, got {mach!r}")
    return m


def safe_envelope(
    mach: Sequence[float] | np.ndarray,
    q_flutter_pa: Sequence[float | None] | np.ndarray,
    margin: float = DEFAULT_MARGIN,
    altitude_range_m: tuple[float, float] = DEFAULT_ALTITUDE_RANGE_M,
) -> Envelope:
    """Envelope from flutter dynamic pressures q_f (Pa; None/NaN/inf = no flutter) at Mach numbers ``mach``."""
    m = _as_machs(mach)
    qf = np.array([math.inf if (v is None or not math.isfinite(float(v))) else float(v) for v in q_flutter_pa])
    if qf.shape != m.shape:
        raise InputError("q_flutter_pa", f"needs one value per Mach ({m.size}), got {qf.size}")
    if np.any(qf <= 0):
        raise InputError("q_flutter_pa", "flutter dynamic pressures must be > 0")
    if not (math.isfinite(margin) and margin >= 1.0):
        raise InputError("margin", f"must be a speed margin factor >= 1, got {margin!r}")
    h_lo, h_hi = (float(x) for x in altitude_range_m)
    if not (math.isfinite(h_lo) and math.isfinite(h_hi) and h_lo < h_hi):
        raise InputError("altitude_range_m", f"must be (low, high) with low < high, got {altitude_range_m!r}")
    q_safe = qf / margin**2
    alt = np.empty(m.size)
    status: list[str] = []
    for i, (mi, qs) in enumerate(zip(m, q_safe, strict=True)):
        if qs >= flight_dynamic_pressure(float(mi), h_lo):
            alt[i], st = h_lo, "safe-everywhere"
        elif qs < flight_dynamic_pressure(float(mi), h_hi):
            alt[i], st = h_hi, "unsafe-in-range"
        else:
            alt[i], st = altitude_for_dynamic_pressure(float(qs), float(mi)), "ok"
        status.append(st)
    return Envelope(m, qf, q_safe, alt, status, float(margin), np.array([h_lo, h_hi]))


def envelope_from_results(
    results: Sequence[Any],
    margin: float = DEFAULT_MARGIN,
    altitude_range_m: tuple[float, float] = DEFAULT_ALTITUDE_RANGE_M,
) -> Envelope:
    """Envelope from FlutterResult-like objects (.mach, .flutter_found, .q_flutter_pa)."""
    if not results:
        raise InputError("results", "need at least one flutter result")
    machs = [float(r.mach) for r in results]
    qf = [float(r.q_flutter_pa) if r.flutter_found and r.q_flutter_pa is not None else math.inf for r in results]
    return safe_envelope(machs, qf, margin, altitude_range_m)


#: Altitude tolerance (m) of the envelope comparison: flutter points are refined to 1e-4 relative and
#: repeated solves differ at round-off, which must not flip the verdict for a design on the boundary
#: (the baseline compared with itself, for one).
ENVELOPE_TOL_M = 0.01


def compare_envelopes(design: Envelope, benchmark: Envelope, tol_m: float = ENVELOPE_TOL_M) -> EnvelopeComparison:
    """Per-Mach check that the design's safe altitude is not above the benchmark's (+ ``tol_m`` m)."""
    if design.mach.shape != benchmark.mach.shape or not np.allclose(design.mach, benchmark.mach, atol=1e-9):
        raise InputError(
            "benchmark", f"Mach numbers {benchmark.mach.tolist()} differ from the design's {design.mach.tolist()}"
        )
    if not (math.isfinite(tol_m) and tol_m >= 0):
        raise InputError("tol_m", f"must be finite and >= 0, got {tol_m!r}")
    margin_m = benchmark.safe_altitude_m - design.safe_altitude_m
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = design.q_safe_pa / benchmark.q_safe_pa
    ratio = np.where(np.isinf(design.q_safe_pa) & np.isinf(benchmark.q_safe_pa), 1.0, ratio)
    margin_q = (ratio - 1.0) * 100.0
    ok: list[bool] = []
    for i, st in enumerate(design.status):
        if st == "unsafe-in-range":  # both altitudes clamp to the top: compare dynamic pressures
            ok.append(bool(design.q_safe_pa[i] >= benchmark.q_safe_pa[i] * (1.0 - 1e-12)))
        else:
            ok.append(bool(design.safe_altitude_m[i] <= benchmark.safe_altitude_m[i] + tol_m))
    return EnvelopeComparison(design.mach.copy(), ok, margin_m, margin_q, all(ok))
