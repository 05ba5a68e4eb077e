"""pymoo adapter of a FlutterProblem: a vectorized ``Problem`` whose ``_evaluate`` is one batch request.

Needs ``pip install 'romams-client[pymoo]'``; pymoo is imported on first access to ``FlutterPymooProblem``.

    from pymoo.algorithms.soo.nonconvex.ga import GA
    from pymoo.optimize import minimize
    from romams_client.pymoo import FlutterPymooProblem
    res = minimize(FlutterPymooProblem(problem), GA(pop_size=30), ("n_gen", 20), seed=1)

``constrained=False`` (default): one objective, the penalty mass + mu * C (kg), no constraints (the paper's
formulation). ``constrained=True``: objective F = mass (kg) and G = the n_mach + 2 inequality constraints of
:meth:`FlutterProblem.inequality_constraints` (G <= 0), for pymoo's own constraint handling.
"""

from __future__ import annotations

from typing import Any

_CLASS: list[type] = []


def _build() -> type:
    """The pymoo Problem class (created on first use, so importing this module needs no pymoo)."""
    if _CLASS:
        return _CLASS[0]
    import numpy as np
    from pymoo.core.problem import Problem

    from romams_client.problem import FlutterProblem

    class FlutterPymooProblem(Problem):  # type: ignore[misc]
        """Flutter-constrained mass of the service's wing as a vectorized pymoo Problem."""

        def __init__(self, flutter: FlutterProblem, constrained: bool = False) -> None:
            self.flutter = flutter
            self.constrained = bool(constrained)
            n_con = flutter.machs.size + 2 if self.constrained else 0
            super().__init__(n_var=flutter.dim, n_obj=1, n_ieq_constr=n_con, xl=flutter.lower.copy(),
                             xu=flutter.upper.copy())

        def _evaluate(self, x: Any, out: dict[str, Any], *args: Any, **kwargs: Any) -> None:
            """Whole population X [n, d] in one batch request: F (kg) and, when constrained, G."""
            ev = self.flutter.evaluate(np.asarray(x, dtype=float))
            if self.constrained:
                out["F"] = np.where(np.isfinite(ev.mass_kg), ev.mass_kg, ev.objective)[:, None]
                out["G"] = self.flutter.inequality_constraints(ev)
            else:
                out["F"] = ev.objective[:, None]

    _CLASS.append(FlutterPymooProblem)
    return FlutterPymooProblem


def __getattr__(name: str) -> Any:
    """``romams_client.pymoo.FlutterPymooProblem`` imports pymoo on first access."""
    if name == "FlutterPymooProblem":
        return _build()
    raise AttributeError(name)
