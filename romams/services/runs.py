"""Runs: how one evaluated design of a batch becomes a compact run evaluation, and a run's summary.

Feasibility follows the client's ``FlutterProblem`` (the ROM-AMS paper's constraints): the safe envelope not above
the baseline's at any Mach (within ``envelope_tol_m``), no single-degree-of-freedom flutter, every mode fitted with
MAC >= ``mac_threshold``, and a mass. The objective is mass + mu * C with the paper's binary C (1 when infeasible)
or, with ``penalty: "graded"``, the client's graded C (``penalty_factor``). Flutter rows keep 6 significant digits;
the design vector is kept exactly.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

#: a run's settings and their defaults (the client's FlutterProblem defaults)
DEFAULT_SETTINGS: dict[str, Any] = {"mu_kg": 10.0, "mac_threshold": 0.98, "envelope_tol_m": 0.01, "penalty": "binary"}
#: per-Mach flutter row of a run evaluation
FLUTTER_FIELDS = ("mach", "v_eas_m_s", "frequency_hz", "flutter_mode", "safe_altitude_m",
                  "benchmark_safe_altitude_m")


def _sig(x: Any, digits: int = 6) -> float | None:
    """``x`` rounded to ``digits`` significant digits (None for a missing or non-finite value)."""
    if x is None:
        return None
    x = float(x)
    if not math.isfinite(x):
        return None
    return float(f"{x:.{digits}g}")


def feasible(summary: Mapping[str, Any], settings: Mapping[str, Any]) -> tuple[bool, bool | None]:
    """(feasible, envelope_ok) of one design's summary under a run's settings."""
    margin = summary.get("envelope_margin_m")
    env_ok = summary.get("envelope_ok")
    if env_ok is not None and not env_ok and margin:
        env_ok = all(m is not None and m >= -float(settings["envelope_tol_m"]) for m in margin)
    mac = summary.get("mac") or []
    min_mac = min(mac) if mac else summary.get("min_mac")
    sdoff = bool(summary.get("sdoff")) or any(bool(r.get("sdoff")) for r in summary.get("results") or [])
    ok = ((env_ok is None or bool(env_ok)) and not sdoff and min_mac is not None
          and float(min_mac) >= float(settings["mac_threshold"]) and summary.get("mass_kg") is not None)
    return ok, None if env_ok is None else bool(env_ok)


def penalty_factor(summary: Mapping[str, Any], settings: Mapping[str, Any], ok: bool,
                   env_ok: bool | None) -> float:
    """C of the objective mass + mu C (0 when feasible). Binary: 1. Graded (the client's FlutterProblem
    ``penalty="graded"``): 1 + the envelope excess summed over the Machs (km, when the envelope fails) + the MAC
    deficit below the threshold in units of 0.02 + the number of Machs with single-degree-of-freedom flutter."""
    if ok:
        return 0.0
    if settings.get("penalty", "binary") != "graded":
        return 1.0
    margin = [m for m in summary.get("envelope_margin_m") or [] if m is not None]
    excess_km = sum(max(-float(m), 0.0) for m in margin) / 1e3 if env_ok is False else 0.0
    mac = summary.get("mac") or []
    min_mac = min(mac) if mac else summary.get("min_mac")
    deficit = max(float(settings["mac_threshold"]) - (0.0 if min_mac is None else float(min_mac)), 0.0) / 0.02
    n_sdoff = sum(bool(r.get("sdoff")) for r in summary.get("results") or [])
    return 1.0 + excess_km + deficit + n_sdoff


def flutter_rows(summary: Mapping[str, Any]) -> list[list[Any]]:
    """Per-Mach [mach, flutter EAS (m/s), f_f (Hz), mode, safe altitude (m), benchmark safe altitude (m)] of a
    summary. The equivalent airspeed carries the flutter dynamic pressure on any sweep (the true airspeed of a
    constant-speed sweep is the same for every design)."""
    margin = summary.get("envelope_margin_m") or []
    out = []
    for i, r in enumerate(summary.get("results") or []):
        alt = r.get("safe_altitude_m")
        bench = None if alt is None or i >= len(margin) or margin[i] is None else float(alt) + float(margin[i])
        out.append([_sig(r.get("mach")), _sig(r.get("v_eas_m_s")), _sig(r.get("frequency_hz")),
                    r.get("flutter_mode"), _sig(alt), _sig(bench)])
    return out


def compact_row(design: Sequence[float] | None, summary: Mapping[str, Any], settings: Mapping[str, Any],
                job_id: str | None = None) -> dict[str, Any]:
    """The run evaluation of one design: design vector, mass (kg), objective (kg), flags, flutter rows."""
    x = [float(v) for v in design] if design is not None else []
    if "error" in summary:
        return {"job_id": job_id, "x": x, "mass_kg": None, "objective": None, "feasible": False,
                "envelope_ok": None, "min_mac": None, "flutter": [], "error": str(summary["error"])[:2000],
                "evaluation_id": None}
    ok, env_ok = feasible(summary, settings)
    mass = None if summary.get("mass_kg") is None else float(summary["mass_kg"])
    c = penalty_factor(summary, settings, ok, env_ok)
    objective = None if mass is None else mass + float(settings["mu_kg"]) * c
    mac = summary.get("mac") or []
    return {"job_id": job_id, "x": x, "mass_kg": mass, "objective": objective, "feasible": ok, "envelope_ok": env_ok,
            "min_mac": _sig(min(mac) if mac else summary.get("min_mac"), 8), "flutter": flutter_rows(summary),
            "error": None, "evaluation_id": None}


def run_settings(given: Mapping[str, Any] | None) -> dict[str, Any]:
    """A run's settings: the defaults overridden by the given values."""
    return {**DEFAULT_SETTINGS, **{k: v for k, v in (given or {}).items() if v is not None}}


def run_summary(run: Mapping[str, Any], counts: Mapping[str, Any], best: Mapping[str, Any] | None,
                active_jobs: int) -> dict[str, Any]:
    """A run with its counts, best design so far and status ("running" while a batch is queued or running)."""
    n = int(counts["n_evaluations"])
    return {**run, **counts, "bytes_per_design": None if n == 0 else counts["payload_bytes"] / n,
            "best": best, "best_objective": None if best is None else best["objective"],
            "status": "running" if active_jobs else ("empty" if n == 0 else "idle"), "active_jobs": active_jobs}
