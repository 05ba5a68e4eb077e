"""Sampling of the UQ example (examples/uq_flutter.py): clipped normal scatter about a nominal design."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest
from live_service import ROOT

spec = importlib.util.spec_from_file_location("uq_flutter", ROOT / "examples/uq_flutter.py")
uq = importlib.util.module_from_spec(spec)
spec.loader.exec_module(uq)

LOWER = np.array([0.15, 0.15, 0.60, 0.0, 0.5, 0.5, 0.5])
UPPER = np.array([0.70, 0.70, 0.85, 0.105, 2.0, 2.0, 1.0])


def test_scatter_has_the_requested_std_inside_the_bounds() -> None:
    nominal = np.array([0.4, 0.4, 0.7, 0.05, 1.0, 1.0, 0.75])  # far from the bounds for 2 % scatter
    x, sigma = uq.scatter_samples(nominal, np.full(7, 0.02), LOWER, UPPER, 20_000, seed=1)
    assert x.shape == (20_000, 7)
    assert sigma == pytest.approx(0.02 * nominal, rel=1e-12)
    # sample mean within 4 standard errors, sample std within 3 % (n = 20 000: se of std ~ 0.5 %)
    assert np.all(np.abs(x.mean(axis=0) - nominal) < 4 * sigma / np.sqrt(len(x)))
    assert x.std(axis=0, ddof=1) == pytest.approx(sigma, rel=0.03)


def test_scatter_is_clipped_and_zero_nominal_uses_the_range() -> None:
    nominal = np.array([0.15, 0.70, 0.85, 0.0, 2.0, 0.5, 1.0])  # every variable at a bound
    x, sigma = uq.scatter_samples(nominal, np.full(7, 0.05), LOWER, UPPER, 4000, seed=2)
    assert np.all(x >= LOWER) and np.all(x <= UPPER)
    assert sigma[3] == pytest.approx(0.05 * 0.105, rel=1e-12)  # nominal 0 kg: 5 % of the 0..0.105 kg range
    # half of each clipped normal sits on its bound
    at_bound = np.mean(np.isclose(x, nominal), axis=0)
    assert at_bound == pytest.approx(np.full(7, 0.5), abs=0.04)


def test_bad_input_names_the_field() -> None:
    with pytest.raises(ValueError, match="rel_std"):
        uq.scatter_samples(np.full(7, 0.6), np.full(7, -0.1), LOWER, UPPER, 10, 0)
    with pytest.raises(ValueError, match="design"):
        uq.scatter_samples(np.full(7, 5.0), np.full(7, 0.1), LOWER, UPPER, 10, 0)
    names = [f"x{i}" for i in range(1, 8)]
    assert uq.parse_pairs("x1=0.2, x4=0.01", names, "--design") == {"x1": 0.2, "x4": 0.01}
    with pytest.raises(ValueError, match="--design"):
        uq.parse_pairs("x9=1", names, "--design")
    with pytest.raises(ValueError, match="x2: not a number"):
        uq.parse_pairs("x2=abc", names, "--design")


def test_cap_warnings_name_the_mach_and_the_cap() -> None:
    machs = np.array([0.87, 0.95])
    status = np.array([["ok", "unsafe-in-range"]] * 8 + [["ok", "ok"]] * 2, dtype=object)
    found = np.ones((10, 2), dtype=bool)
    found[:3, 0] = False  # 30 % without flutter at M 0.87
    warnings = uq.cap_warnings(machs, status, found)
    assert len(warnings) == 2
    assert warnings[0].startswith("WARNING: M 0.87: 30.0 % without flutter in the speed sweep")
    assert "M 0.95: 80.0 % at the top of the altitude range" in warnings[1]
    assert uq.cap_warnings(machs, np.full((10, 2), "ok", dtype=object), np.ones((10, 2), dtype=bool)) == []


def test_default_design_is_inside_the_bounds_and_not_the_papers() -> None:
    x = np.array([uq.DEFAULT_DESIGN[f"x{i}"] for i in range(1, 8)])
    assert np.all((x >= LOWER) & (x <= UPPER))
    assert uq.DEFAULT_DESIGN != uq.PAPER_OPTIMUM


def _de_example():
    """examples/optimize_cropped_delta.py as a module."""
    sp = importlib.util.spec_from_file_location("optimize_cropped_delta", ROOT / "examples/optimize_cropped_delta.py")
    mod = importlib.util.module_from_spec(sp)
    sp.loader.exec_module(mod)
    return mod


def test_examples_print_results_on_stdout_only(capsys) -> None:
    env = [{"mach": 0.87, "safe_altitude_m": 9000.0, "benchmark_safe_altitude_m": 9500.0}]
    table8 = [{k: None for k in ("v_ams", "v_pms", "v_error_pct", "omega_ams", "omega_pms", "omega_error_pct")}]
    de = {"optimum_feasible": True, "optimum": {"x1": 0.5}, "optimum_mass_kg": 0.25, "baseline_mass_kg": 0.24,
          "mass_reduction_pct": -4.1667, "paper": {"mass_reduction_pct": 28.46}, "evaluations": 18,
          "batch_requests": 3, "optimization_s": 7.0, "setup_s": 0.2, "envelope": env,
          "verification": {"note": "", "table8": table8}}
    _de_example()._print_result(de)
    out, err = capsys.readouterr()
    assert err == "" and "mass 0.2500 kg vs baseline 0.2400 kg: +4.17 % (paper: -28.46 %)" in out
    assert "verification: none" in out
    stats = {"n": 4, "mean": 170.0, "std": 4.5, "percentiles": {"5": 163.0, "50": 170.0, "95": 177.0}}
    uq_summary = {"nominal": {"x1": 0.61}, "nominal_result": {"feasible": True, "mass_kg": 0.2745}, "samples": 4,
                  "wall_s": 1.0, "designs_per_s": 4.0, "batch_requests": 1, "mass_kg": {"mean": 0.27, "std": 0.004},
                  "probability_constraint_violated": 0.0, "benchmark_safe_altitude_m": [12997.0],
                  "per_mach": [{"mach": 0.91, "v_eas_m_s": stats, "safe_altitude_m": stats,
                                "no_flutter_fraction": 0.0, "at_cap_fraction": 0.25}]}
    lines = uq.report_lines(uq_summary)
    assert lines[0].endswith("(feasible, mass 0.2745 kg)") and lines[3] == "P(constraint violated) = 0.000"
    assert lines[-1].split() == ["0.91", "170.0", "4.50", "163.0", "177.0", "170", "12997", "0.0", "25.0"]
