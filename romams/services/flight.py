"""The flight condition of a flutter evaluation: one default for the CLI, the API, the workers and the demo.

Default: the constant-speed sweep at the ISA reference altitude of 10 km (V = M a_ref fixed, density
swept: the ROM-AMS paper's eq. 14, Mach-consistent for a Mach-specific ROM), Tustin coupling, the wing's
own modal damping. Mach 0 is incompressible: a constant speed is undefined there, so Mach 0 always uses
the constant-density sweep at rho_ref (``romams_core.evaluate.INCOMPRESSIBLE_SWEEP``), with a speed range
given (``v_max_m_s``) or defaulted from the structure by the core. Every result states the sweep, the
reference altitude and the density it used.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace
from typing import Any

from romams.services.errors import InvalidInput, from_input_error
from romams_core.errors import InputError
from romams_core.flutter import COUPLINGS, DEFAULT_ALTITUDE_REF_M, SWEEPS
from romams_core.projection_residual import PROJECTION_CORRECTIONS
from romams_core.validation import check_choice, check_number, finite_positive

DEFAULT_SWEEP = "constant-speed"
DEFAULT_COUPLING = "tustin"
DEFAULT_PROJECTION_CORRECTION = "auto"
ALTITUDE_LIMITS_M = (0.0, 20_000.0)


@dataclass(frozen=True)
class FlightCondition:
    """Sweep parametrization and reference state of a flutter search (SI units; None = default/derived)."""

    sweep: str = DEFAULT_SWEEP
    altitude_ref_m: float = DEFAULT_ALTITUDE_REF_M
    rho_ref: float | None = None  # kg/m^3; overrides the ISA density at altitude_ref_m
    v_max_m_s: float | None = None  # constant-density range (m/s); default from Mach or the structure
    q_max_pa: float | None = None  # constant-speed range (Pa); default 4 x q at the reference state
    coupling: str = DEFAULT_COUPLING
    #: "dlm": the modes' part outside the basis span added by the DLM (romams_core.projection_residual); "auto":
    #: dlm on TSD ROMs, none on the linear solvers' (services.evaluation.projection_choice)
    projection_correction: str = DEFAULT_PROJECTION_CORRECTION

    def __post_init__(self) -> None:
        try:  # the core's validators; their typed errors become the service's InvalidInput (same field)
            check_choice("sweep", self.sweep, SWEEPS)
            check_choice("coupling", self.coupling, COUPLINGS)
            check_choice("projection_correction", self.projection_correction, PROJECTION_CORRECTIONS)
            lo, hi = ALTITUDE_LIMITS_M
            alt = check_number("altitude_ref_m", self.altitude_ref_m, lo, strict=False, upper=hi, upper_strict=False)
            object.__setattr__(self, "altitude_ref_m", alt)
            for name in ("rho_ref", "v_max_m_s", "q_max_pa"):
                value = getattr(self, name)
                object.__setattr__(self, name, None if value is None else finite_positive(name, value))
        except InputError as exc:
            raise from_input_error(exc) from exc

    def flutter_options(self) -> dict[str, Any]:
        """Keyword arguments of romams_core.flutter.flutter_analysis (besides sweep, coupling and zeta)."""
        opts: dict[str, Any] = {"altitude_ref_m": self.altitude_ref_m}
        if self.rho_ref is not None:
            opts["rho_ref"] = self.rho_ref
        if self.v_max_m_s is not None:
            opts["v_max"] = self.v_max_m_s
        if self.q_max_pa is not None:
            opts["q_max"] = self.q_max_pa
        return opts

    def to_json(self) -> dict[str, Any]:
        """The condition as JSON (request side: what was asked, before per-Mach resolution)."""
        return asdict(self)

    @classmethod
    def from_options(cls, **options: Any) -> FlightCondition:
        """Condition from optional keyword values (None = default), e.g. from a request or CLI flags."""
        given = {k: v for k, v in options.items() if v is not None}
        unknown = sorted(set(given) - {f for f in cls.__dataclass_fields__})
        if unknown:
            raise InvalidInput(unknown[0], "not a flight-condition setting")
        return replace(cls(), **given)


DEFAULT_CONDITION = FlightCondition()
