"""The flight condition of a flutter evaluation: one default for the CLI, the API, the workers and the demo.

Default: the constant-speed sweep at the ISA reference altitude of 10 km (V = M a_ref fixed, density
swept: the ROM-AMS paper's eq. 14, Mach-consistent for a Mach-specific ROM), Tustin coupling, the wing's
own modal damping. Mach 0 is incompressible: a constant speed is undefined there, so Mach 0 always uses
the constant-density sweep at rho_ref (``romams_core.evaluate.INCOMPRESSIBLE_SWEEP``), with a speed range
given (``v_max_m_s``) or defaulted from the structure by the core. Every result states the sweep, the
reference altitude and the density it used.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from typing import Any

from romams.services.errors import InvalidInput
from romams_core.flutter import COUPLINGS, DEFAULT_ALTITUDE_REF_M, SWEEPS

DEFAULT_SWEEP = "constant-speed"
DEFAULT_COUPLING = "tustin"
ALTITUDE_LIMITS_M = (0.0, 20_000.0)


def _positive_or_none(name: str, value: Any) -> float | None:
    """``value`` as a finite float > 0, or None; InvalidInput naming ``name`` otherwise."""
    if value is None:
        return None
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InvalidInput(name, f"must be a number, got {value!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise InvalidInput(name, f"must be finite and > 0, got {value!r}")
    return v


@dataclass(frozen=True)
class FlightCondition:
    """Sweep parametrization and reference state of a flutter search (SI units; None = default/derived)."""

    sweep: str = DEFAULT_SWEEP
    altitude_ref_m: float = DEFAULT_ALTITUDE_REF_M
    rho_ref: float | None = None  # kg/m^3; overrides the ISA density at altitude_ref_m
    v_max_m_s: float | None = None  # constant-density range (m/s); default from Mach or the structure
    q_max_pa: float | None = None  # constant-speed range (Pa); default 4 x q at the reference state
    coupling: str = DEFAULT_COUPLING

    def __post_init__(self) -> None:
        if self.sweep not in SWEEPS:
            raise InvalidInput("sweep", f"must be one of {list(SWEEPS)}, got {self.sweep!r}")
        if self.coupling not in COUPLINGS:
            raise InvalidInput("coupling", f"must be one of {list(COUPLINGS)}, got {self.coupling!r}")
        try:
            alt = float(self.altitude_ref_m)
        except (TypeError, ValueError):
            raise InvalidInput("altitude_ref_m", f"must be a number, got {self.altitude_ref_m!r}") from None
        lo, hi = ALTITUDE_LIMITS_M
        if not (math.isfinite(alt) and lo <= alt <= hi):
            raise InvalidInput("altitude_ref_m", f"must be within [{lo:g}, {hi:g}] m, got {self.altitude_ref_m!r}")
        object.__setattr__(self, "altitude_ref_m", alt)
        for name in ("rho_ref", "v_max_m_s", "q_max_pa"):
            object.__setattr__(self, name, _positive_or_none(name, getattr(self, name)))

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
