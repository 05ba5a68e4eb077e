"""OpenMDAO wrapper of a FlutterProblem (optional: ``pip install openmdao``; imported only when used).

``FlutterComponent(problem=FlutterProblem(...))`` is an ExplicitComponent with one input ``x`` (the
design vector, in the wing's variable order) and outputs ``mass`` (kg), ``objective`` (kg, penalty
form), ``envelope_margin`` (m, one per Mach: baseline safe altitude minus the design's, >= 0 is
feasible), ``v_flutter`` (m/s per Mach), ``min_mac``, ``sdoff`` and ``feasible`` (0/1). Each compute is
one HTTP evaluation. Derivatives: by finite differences when ``fd_step`` is set (each one costs a
request), otherwise none (for gradient-free drivers: DOE, genetic, differential evolution).

Batched: ``FlutterPopulationComponent(problem=..., pop_size=n)`` takes the whole population ``X`` [n, d] as
one input and answers ``objective``, ``mass``, ``feasible``, ``min_mac``, ``sdoff`` [n] and
``envelope_margin``, ``v_flutter`` [n, n_mach] with one batch request per compute. OpenMDAO's own
``SimpleGADriver`` / ``DifferentialEvolutionDriver`` run the model once per design (their parallel mode needs MPI
and still runs one design per model copy), so ``PopulationDEDriver`` drives the population matrix instead:
DE/rand/1/bin with greedy selection, one ``run_model`` (= one request) per generation.
"""

from __future__ import annotations

from typing import Any

_CLASS: list[type] = []


def _build() -> type:
    """The component class (created on first use, so that importing this module needs no openmdao)."""
    if _CLASS:
        return _CLASS[0]
    import numpy as np
    import openmdao.api as om

    from romams_client.problem import FlutterProblem

    class FlutterComponent(om.ExplicitComponent):  # type: ignore[misc]
        """Flutter-constrained mass of one structure, evaluated by the romams service."""

        def initialize(self) -> None:
            self.options.declare("problem", types=FlutterProblem, desc="FlutterProblem bound to a client and wing")
            self.options.declare("fd_step", default=None, allow_none=True, types=float,
                                 desc="relative finite-difference step for partials (None: no derivatives)")

        def setup(self) -> None:
            p: FlutterProblem = self.options["problem"]
            k = p.machs.size
            self.add_input("x", val=0.5 * (p.lower + p.upper), desc="design vector: " + ", ".join(p.names))
            self.add_output("mass", val=0.0, units="kg")
            self.add_output("objective", val=0.0, units="kg", desc="mass + mu * C(x)")
            self.add_output("envelope_margin", val=np.zeros(k), units="m")
            self.add_output("v_flutter", val=np.zeros(k), units="m/s")
            self.add_output("min_mac", val=0.0)
            self.add_output("sdoff", val=0.0)
            self.add_output("feasible", val=0.0)

        def setup_partials(self) -> None:
            step = self.options["fd_step"]
            if step is not None:
                self.declare_partials(["mass", "objective", "envelope_margin", "v_flutter"], "x", method="fd",
                                      step=step, step_calc="rel")

        def compute(self, inputs: Any, outputs: Any) -> None:
            p: FlutterProblem = self.options["problem"]
            ev = p.evaluate(np.asarray(inputs["x"], dtype=float)[None, :])
            outputs["mass"] = ev.mass_kg[0]
            outputs["objective"] = ev.objective[0]
            outputs["envelope_margin"] = ev.envelope_margin_m[0]
            outputs["v_flutter"] = ev.v_eas_m_s[0]  # equivalent airspeed: carries q_f on every sweep
            outputs["min_mac"] = ev.min_mac[0]
            outputs["sdoff"] = float(ev.sdoff[0])
            outputs["feasible"] = float(ev.feasible[0])

    _CLASS.append(FlutterComponent)
    return FlutterComponent


def __getattr__(name: str) -> Any:
    """``FlutterComponent``, ``FlutterPopulationComponent``, ``PopulationDEDriver`` import openmdao on first access."""
    if name == "FlutterComponent":
        return _build()
    if name in ("FlutterPopulationComponent", "PopulationDEDriver"):
        from romams_client import openmdao_batch

        return getattr(openmdao_batch, name)
    raise AttributeError(name)
