"""A short flutter-constrained DE optimization over HTTP against a live embedded service.

The example's own driver (examples/optimize_cropped_delta.py: scipy DE, vectorized, deferred
updating, LHS initial population, paper's F and CR) runs a few generations on a small basis and ROMs
at two Mach numbers. Checked: one batch request per generation, constraints evaluated for every
design (and active: some designs fail them), the best feasible mass never increases and ends lower
than in the initial population, and the reported optimum agrees with an independent evaluation.
"""

from __future__ import annotations

import importlib.util
import math

import numpy as np
import pytest
from fast_settings import DLM_FAST
from live_service import ROOT, LiveService

from client import FlutterProblem, RomamsClient

MACHS = (0.87, 0.95)
POP, GENERATIONS = 10, 8


def _example():
    """The example script as a module."""
    spec = importlib.util.spec_from_file_location("optimize_cropped_delta", ROOT / "examples/optimize_cropped_delta.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.mark.slow
def test_short_de_optimization_over_http(tmp_path) -> None:
    ex = _example()
    with LiveService(tmp_path / "svc", concurrency=1) as svc, RomamsClient(svc.url, timeout=120) as client:
        wid = ex.prepare_service(client, "cd-e2e", MACHS, samples=10, basis_seed=1, train_options=DLM_FAST,
                                 log=lambda m: None, progress=False)  # the default solver: dlm
        problem = FlutterProblem(client, wid, machs=MACHS, mu=10.0)
        baseline = problem.baseline()
        assert baseline["mass_kg"] == pytest.approx(0.24, rel=0.02)
        sent = client.requests_sent
        run = ex.run_de(problem, generations=GENERATIONS, popsize=POP, seed=4, log=lambda m: None)

        # one batch request per generation (initial population + GENERATIONS trial populations)
        assert problem.n_calls == GENERATIONS + 1 == client.requests_sent - sent
        assert problem.n_evaluations == POP * (GENERATIONS + 1) == run["nfev"]
        hist = run["history"]
        assert [h["generation"] for h in hist] == list(range(GENERATIONS + 1))

        # constraints are evaluated for every design, and they bind
        evs = problem.history
        assert len(evs) == GENERATIONS + 1
        for ev in evs:
            assert ev.envelope_margin_m.shape == (POP, len(MACHS))
            assert np.all(np.isfinite(ev.min_mac)) and np.all(np.isfinite(ev.mass_kg))
            assert np.all(ev.objective == pytest.approx(ev.mass_kg + 10.0 * ~ev.feasible, rel=1e-12))
        feasible = np.concatenate([ev.feasible for ev in evs])
        assert 0 < feasible.sum() < feasible.size

        # best feasible mass: never up (DE selection is elitist), and down from generation 0 to the end
        best = np.array([h["best_mass_kg"] if h["best_feasible"] else math.inf for h in hist])
        assert np.all(np.diff(best) <= 1e-12)
        finite = best[np.isfinite(best)]
        assert finite.size >= GENERATIONS // 2, best  # feasible designs are found early
        assert best[-1] < finite[0], best  # and the lightest one gets lighter
        assert best[-1] == pytest.approx(run["objective"], rel=1e-12)
        print("best feasible mass by generation (kg):", np.round(best, 5).tolist())

        # the optimum, evaluated on its own, is feasible with the same mass
        opt = client.evaluate(wid, run["x"], machs=list(MACHS), store=False)
        assert opt["mass_kg"] == pytest.approx(best[-1], rel=1e-9)
        assert not opt["sdoff"] and min(opt["mac"]) >= 0.98
        assert min(opt["envelope_margin_m"]) >= -0.01
