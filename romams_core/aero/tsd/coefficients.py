"""Coefficients of the conservative transonic small-disturbance (TSD) equation (dimensionless).

    d/dt(-A phi_t - B phi_x) + d/dx(E phi_x + F phi_x^2 + G phi_y^2) + d/dy(phi_y + H phi_x phi_y) + d/dz(phi_z) = 0

A = M^2, B = 2 M^2 and E = 1 - M^2 are fixed by the linearized potential equation in wing axes; F, G and H are
the modelling choice (docs/aerodynamics.md section 14 gives the derivation and the sets).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from romams_core.errors import InputError

GAMMA = 1.4
COEFFICIENT_SETS = ("ames", "nlr", "2d")


@dataclass(frozen=True)
class TsdCoefficients:
    """The six TSD coefficients at one Mach number and the set they come from."""

    mach: float
    name: str
    A: float
    B: float
    E: float
    F: float
    G: float
    H: float

    @property
    def u_star(self) -> float:
        """Sonic perturbation velocity phi_x (units of U) where E + 2 F u changes sign."""
        return -self.E / (2.0 * self.F) if self.F != 0.0 else math.inf

    @property
    def cp_star(self) -> float:
        """Sonic pressure coefficient of the linear Cp = -2 (phi_x + phi_t)."""
        return -2.0 * self.u_star


def tsd_coefficients(mach: float, name: str = "ames", gamma: float = GAMMA) -> TsdCoefficients:
    """TSD coefficients at free-stream ``mach`` (0 < M < 1) for the set "ames" (default), "nlr" or "2d"."""
    if not (math.isfinite(mach) and 0.0 < mach < 1.0):
        raise InputError("mach", f"the TSD solver needs 0 < M < 1 (supersonic is not supported), got {mach!r}")
    m2 = mach * mach
    if name == "ames":
        f, g, h = -0.5 * (gamma + 1.0) * m2, 0.5 * (gamma - 3.0) * m2, -(gamma - 1.0) * m2
    elif name == "nlr":
        f, g, h = -0.5 * (3.0 - (2.0 - gamma) * m2) * m2, -0.5 * m2, -m2
    elif name == "2d":
        f, g, h = -0.5 * (gamma + 1.0) * m2, 0.0, 0.0
    else:
        raise InputError("coefficients", f"must be one of {COEFFICIENT_SETS}, got {name!r}")
    return TsdCoefficients(mach=float(mach), name=name, A=m2, B=2.0 * m2, E=1.0 - m2, F=f, G=g, H=h)
