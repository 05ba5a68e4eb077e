"""Batched OpenMDAO pieces: a population component (one request per compute) and a DE driver for it.

Imported through :mod:`romams_client.openmdao` (``FlutterPopulationComponent``, ``PopulationDEDriver``); needs
``pip install 'romams-client[openmdao]'``.

    model.add_subsystem("flutter", FlutterPopulationComponent(problem=problem, pop_size=20), promotes=["*"])
    model.add_design_var("X", lower=np.tile(problem.lower, (20, 1)), upper=np.tile(problem.upper, (20, 1)))
    model.add_objective("objective")            # one value per design
    prob.driver = PopulationDEDriver(max_gen=50, seed=1)
"""

from __future__ import annotations

from typing import Any

import numpy as np
import openmdao.api as om
from openmdao.core.driver import Driver, RecordingDebugging

from romams_client.problem import FlutterProblem


class FlutterPopulationComponent(om.ExplicitComponent):  # type: ignore[misc]
    """Flutter-constrained mass of a whole population X [pop_size, d], one batch request per compute."""

    def initialize(self) -> None:
        self.options.declare("problem", types=FlutterProblem, desc="FlutterProblem bound to a client and wing")
        self.options.declare("pop_size", types=int, lower=1, desc="number of designs n (rows of X)")

    def setup(self) -> None:
        p: FlutterProblem = self.options["problem"]
        n, k = self.options["pop_size"], p.machs.size
        self.add_input("X", val=np.tile(0.5 * (p.lower + p.upper), (n, 1)), desc="designs: " + ", ".join(p.names))
        self.add_output("objective", val=np.zeros(n), units="kg", desc="mass + mu * C(x) per design")
        self.add_output("mass", val=np.zeros(n), units="kg")
        self.add_output("envelope_margin", val=np.zeros((n, k)), units="m")
        self.add_output("v_flutter", val=np.zeros((n, k)), units="m/s", desc="equivalent airspeed at flutter")
        self.add_output("min_mac", val=np.zeros(n))
        self.add_output("sdoff", val=np.zeros(n))
        self.add_output("feasible", val=np.zeros(n))

    def compute(self, inputs: Any, outputs: Any) -> None:
        """All designs of X in one batch request."""
        ev = self.options["problem"].evaluate(np.asarray(inputs["X"], dtype=float))
        outputs["objective"] = ev.objective
        outputs["mass"] = ev.mass_kg
        outputs["envelope_margin"] = ev.envelope_margin_m
        outputs["v_flutter"] = ev.v_eas_m_s
        outputs["min_mac"] = ev.min_mac
        outputs["sdoff"] = ev.sdoff.astype(float)
        outputs["feasible"] = ev.feasible.astype(float)


def _lhs(n: int, d: int, rng: np.random.Generator) -> np.ndarray:
    """Latin-hypercube sample of n points in the unit cube [0, 1]^d."""
    return (rng.permuted(np.tile(np.arange(n), (d, 1)), axis=1).T + rng.random((n, d))) / n


class PopulationDEDriver(Driver):  # type: ignore[misc]
    """DE/rand/1/bin over a population-matrix design variable: one ``run_model`` per generation.

    The model has exactly one design variable, the population X [n, d] (bounds per element), and one
    objective with one value per design. Generation 0 is a Latin hypercube (or X's value when ``init="value"``);
    each later generation evaluates all n trial vectors at once and keeps each trial that is not worse than its
    parent. After ``run``: ``best_x`` [d], ``best_f``, ``history`` (best objective after each generation) and
    ``population`` / ``fitness``; the model holds the last evaluated population.
    """

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.supports["optimization"] = True
        self.supports["gradients"] = False  # gradient-free: no derivative checks at setup
        self.supports["inequality_constraints"] = False
        self.supports["equality_constraints"] = False
        self.supports._read_only = True

    def _declare_options(self) -> None:
        self.options.declare("max_gen", default=10, types=int, lower=0, desc="generations after the initial one")
        self.options.declare("F", default=0.55, types=float, desc="differential weight")
        self.options.declare("CR", default=0.7, types=float, desc="crossover probability")
        self.options.declare("seed", default=0, types=int)
        self.options.declare("init", default="lhs", values=["lhs", "value"], desc="initial population")

    def _evaluate(self, name: str, x: np.ndarray) -> np.ndarray:
        """Objective [n] of population x [n, d]: one model run."""
        self._problem().set_val(name, x)
        with RecordingDebugging(self._get_name(), self.iter_count, self):
            self._run_solve_nonlinear()
        self.iter_count += 1
        return np.asarray(next(iter(self.get_objective_values().values())), dtype=float).ravel()

    def run(self) -> bool:
        """Evolve the population for ``max_gen`` generations; returns False (no failure)."""
        self._check_for_missing_objective()
        if len(self._designvars) != 1:
            raise ValueError("PopulationDEDriver: the model needs exactly one design variable, the population X")
        name, meta = next(iter(self._designvars.items()))
        x0 = np.asarray(self._problem().get_val(name), dtype=float)
        if x0.ndim != 2:
            raise ValueError(f"PopulationDEDriver: design variable {name!r} must be a [pop, d] matrix, got {x0.shape}")
        n, d = x0.shape
        lo = np.broadcast_to(meta["lower"], (n * d,)).reshape(n, d)
        hi = np.broadcast_to(meta["upper"], (n * d,)).reshape(n, d)
        rng = np.random.default_rng(self.options["seed"])
        pop = x0.copy() if self.options["init"] == "value" else lo + _lhs(n, d, rng) * (hi - lo)
        fit = self._evaluate(name, pop)
        self.history = [float(np.min(fit))]
        for _ in range(self.options["max_gen"]):
            r = np.array([rng.choice(np.delete(np.arange(n), i), 3, replace=False) for i in range(n)])
            mutant = pop[r[:, 0]] + self.options["F"] * (pop[r[:, 1]] - pop[r[:, 2]])
            out = (mutant < lo) | (mutant > hi)
            mutant = np.where(out, lo + rng.random((n, d)) * (hi - lo), mutant)  # redraw out-of-bounds genes
            cross = rng.random((n, d)) < self.options["CR"]
            cross[np.arange(n), rng.integers(0, d, n)] = True
            trial = np.where(cross, mutant, pop)
            f_trial = self._evaluate(name, trial)
            keep = f_trial <= fit
            pop, fit = np.where(keep[:, None], trial, pop), np.where(keep, f_trial, fit)
            self.history.append(float(np.min(fit)))
        self.population, self.fitness = pop, fit
        self.best_x, self.best_f = pop[int(np.argmin(fit))].copy(), float(np.min(fit))
        return False
