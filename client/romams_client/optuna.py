"""Optuna ask/tell adapter of a FlutterProblem: one batch request per ``ask`` of n trials.

Needs ``pip install 'romams-client[optuna]'``; optuna is imported only when this module's functions run.

    study = optuna.create_study(sampler=optuna.samplers.NSGAIISampler(population_size=20))
    batch = OptunaBatch(problem, study)
    best = batch.optimize(generations=10, n=20)   # 10 x (20 trials asked, one request, told)
    best.params

The value told is the penalty objective mass + mu * C (kg). The constraints G <= 0 of
:meth:`FlutterProblem.inequality_constraints` are set on every trial with ``Trial.set_constraint`` (Optuna >= 5,
named ``envelope_M<mach>``, ``mac``, ``sdoff``), which Optuna's constrained samplers read, and kept as the user
attribute ``constraints`` for older Optuna's ``constraints_func=`` (:func:`constraints_func`). The user attributes
also carry ``mass_kg`` and ``feasible``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from romams_client.problem import BatchEvaluation, FlutterProblem


def distributions(problem: FlutterProblem) -> dict[str, Any]:
    """Optuna FloatDistributions of the wing's design variables (name -> [lower, upper])."""
    from optuna.distributions import FloatDistribution

    return {n: FloatDistribution(float(lo), float(hi)) for n, lo, hi in zip(problem.names, problem.lower,
                                                                          problem.upper, strict=True)}


def constraints_func(trial: Any) -> list[float]:
    """Constraint values G <= 0 of a finished trial (for Optuna samplers' ``constraints_func``)."""
    return list(trial.user_attrs.get("constraints", [1.0]))


class OptunaBatch:
    """Drives an Optuna ``study`` on ``problem`` with ask/tell: every :meth:`step` is one batch request."""

    def __init__(self, problem: FlutterProblem, study: Any) -> None:
        self.problem = problem
        self.study = study
        self.distributions = distributions(problem)
        self.constraint_names = [f"envelope_M{m:g}" for m in problem.machs] + ["mac", "sdoff"]
        self.best_history: list[float] = []  # best objective told so far, after each step (kg)

    def ask(self, n: int) -> tuple[list[Any], np.ndarray]:
        """Ask ``n`` trials; returns them and their designs X [n, d] in the wing's variable order."""
        if n < 1:
            raise ValueError(f"n: must be >= 1 trials, got {n}")
        trials = [self.study.ask(self.distributions) for _ in range(n)]
        x = np.array([[t.params[name] for name in self.problem.names] for t in trials], dtype=float)
        return trials, x

    def tell(self, trials: list[Any], ev: BatchEvaluation) -> None:
        """Tell every trial its penalty objective (kg), with mass, feasibility and constraints as user attributes."""
        g = self.problem.inequality_constraints(ev)
        for i, trial in enumerate(trials):
            trial.set_user_attr("mass_kg", None if np.isnan(ev.mass_kg[i]) else float(ev.mass_kg[i]))
            trial.set_user_attr("feasible", bool(ev.feasible[i]))
            trial.set_user_attr("constraints", g[i].tolist())
            if hasattr(trial, "set_constraint"):  # optuna >= 5
                for key, value in zip(self.constraint_names, g[i], strict=True):
                    trial.set_constraint(key, float(value))
            self.study.tell(trial, float(ev.objective[i]))

    def step(self, n: int) -> BatchEvaluation:
        """Ask ``n`` trials, evaluate them with one batch request, tell the results."""
        trials, x = self.ask(n)
        ev = self.problem.evaluate(x)
        self.tell(trials, ev)
        best = float(np.min(ev.objective))
        self.best_history.append(min(best, self.best_history[-1]) if self.best_history else best)
        return ev

    def optimize(self, generations: int, n: int) -> Any:
        """Run ``generations`` steps of ``n`` trials each; returns the trial of lowest penalty objective."""
        for _ in range(int(generations)):
            self.step(n)
        done = [t for t in self.study.trials if t.value is not None]
        return min(done, key=lambda t: t.value)
