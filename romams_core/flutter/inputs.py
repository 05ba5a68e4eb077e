"""Input checks of a flutter search (shared with ``romams_core.pk``); a failure is an InputError naming the input."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from romams_core.errors import InputError
from romams_core.statespace import ContinuousSS
from romams_core.validation import check_choice, check_int, finite_positive

SWEEPS = ("constant-density", "constant-speed", "matched")
COUPLINGS = ("tustin", "zoh")


def check_flutter_inputs(
    omega: Any, zeta: Any, c_ref: Any, mach: Any, sweep: str
) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Validated (omega [k] rad/s, zeta [k], c_ref m, mach) of a flutter search; InputError naming the field.

    Mach 0 (an incompressible model) is accepted for the constant-density sweep only: the constant-speed and
    matched sweeps fly at V = M a, which is 0 there (InputError naming ``sweep``).
    """
    check_choice("sweep", sweep, SWEEPS)
    om = np.atleast_1d(np.asarray(omega, dtype=float))
    if om.ndim != 1 or om.size == 0 or not np.all(np.isfinite(om)) or np.any(om <= 0):
        raise InputError("omega", "must be a non-empty 1-D array of finite frequencies > 0 (rad/s)")
    k = om.size
    if zeta is None:
        zt = np.zeros(k)
    else:
        zt = np.asarray(zeta, dtype=float)
        zt = np.broadcast_to(zt, (k,)).copy() if zt.ndim == 0 else zt
        if zt.shape != (k,) or not np.all(np.isfinite(zt)) or np.any(zt < 0) or np.any(zt >= 1):
            raise InputError("zeta", f"must be a scalar or [{k}] array of damping ratios in [0, 1)")
    c = finite_positive("c_ref", c_ref)
    if isinstance(mach, bool) or not (isinstance(mach, int | float | np.integer | np.floating)
                                      and math.isfinite(mach) and mach >= 0):
        raise InputError("mach", f"must be a finite number >= 0, got {mach!r}")
    if sweep != "constant-density" and mach <= 0:
        raise InputError("sweep", f"the {sweep} sweep flies at V = M a and needs mach > 0 (got mach = {mach!r}); "
                                  "use sweep='constant-density' for an incompressible (mach = 0) model")
    return om, zt, c, float(mach)


@dataclass(frozen=True)
class AeroParts:
    """Validated matrices of an aero model with k inputs and outputs: discrete (dt_star > 0) or continuous in t*
    (dt_star = 0; optional D1, D2 feedthrough of du/dt*, d2u/dt*2)."""

    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    d: np.ndarray
    dt_star: float
    d1: np.ndarray | None = None
    d2: np.ndarray | None = None

    @property
    def continuous(self) -> bool:
        """True for a continuous-time model (a rational-function ROM)."""
        return self.dt_star == 0.0


def aero_matrices(aero: Any, k: int) -> AeroParts:
    """Validated matrices of a discrete (A, B, C, D, dt_star) or continuous (ContinuousSS) aero model, k modes."""
    continuous = isinstance(aero, ContinuousSS)
    try:
        a, b, c, d = (np.asarray(getattr(aero, n), dtype=float) for n in ("A", "B", "C", "D"))
        dt_star = 0.0 if continuous else finite_positive("aero.dt_star", aero.dt_star)
    except AttributeError as exc:
        raise InputError("aero", f"needs attributes A, B, C, D, dt_star ({exc})") from None
    na = a.shape[0] if a.ndim == 2 else -1
    if a.ndim != 2 or a.shape != (na, na):
        raise InputError("aero.A", f"must be square, got shape {a.shape}")
    if b.shape != (na, k):
        raise InputError("aero.B", f"must have shape ({na}, {k}) for {k} structural modes, got {b.shape}")
    if c.shape != (k, na):
        raise InputError("aero.C", f"must have shape ({k}, {na}) for {k} structural modes, got {c.shape}")
    extra = {}
    for n in ("D1", "D2") if continuous else ():
        if getattr(aero, n, None) is not None:
            extra[n] = np.asarray(getattr(aero, n), dtype=float)
    for n, m in (("D", d), *extra.items()):
        if m.shape != (k, k):
            raise InputError(f"aero.{n}", f"must have shape ({k}, {k}), got {m.shape}")
    for n, m in (("A", a), ("B", b), ("C", c), ("D", d), *extra.items()):
        if not np.all(np.isfinite(m)):
            raise InputError(f"aero.{n}", "contains non-finite values")
    return AeroParts(a, b, c, d, dt_star, extra.get("D1"), extra.get("D2"))


def check_search_options(coupling: str, n_points: Any, sdoff_share: Any, sdoff_q_factor: Any, rtol: Any) -> None:
    """Options of flutter_analysis: coupling name, coarse point count, SDOFF settings, brentq tolerance."""
    check_choice("coupling", coupling, COUPLINGS)
    check_int("n_points", n_points, 4, 2000)
    if not (isinstance(sdoff_share, int | float | np.floating) and 0.0 < sdoff_share <= 1.0):
        raise InputError("sdoff_share", f"must be in (0, 1], got {sdoff_share!r}")
    if not (isinstance(sdoff_q_factor, int | float | np.floating) and math.isfinite(sdoff_q_factor)
            and sdoff_q_factor >= 1.0):
        raise InputError("sdoff_q_factor", f"must be >= 1, got {sdoff_q_factor!r}")
    finite_positive("rtol", rtol)
