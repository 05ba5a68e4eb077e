"""The three sweep parametrizations of a flutter search.

Each sweep maps a scalar parameter p to the flight condition (V [m/s], rho [kg/m^3]); p = ``p_start`` is q = 0,
where the structural branches start at their in-vacuo poles, and p grows towards higher dynamic pressure:

- ``ConstantDensity``: p = V in (0, v_max] at rho_ref (incompressible models; Mach changes with V).
- ``ConstantSpeed``: p = q in (0, q_max] at V0 = M a_ref (rho = 2 q / V0^2; the ROM-AMS paper's eq. 14).
- ``Matched``: p in [-1, 0) is a density ramp at the top altitude (q from 0 to q(h_top), so the branches can
  be tracked from q = 0), then p = h_top - h with V = M a(h), rho(h) down to the bottom of the range.

``grid(n)`` is the coarse grid of n points (the matched sweep adds its three ramp points in front);
``grid_fixed`` is the part of the sweep that does not depend on n (used for the sweep-independent refinement
resolution and the start of a bracket).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from romams_core.atmosphere import RHO_SEA_LEVEL, isa, isa_table
from romams_core.errors import InputError
from romams_core.validation import finite_positive

DEFAULT_ALTITUDE_REF_M = 10_000.0
K_MIN_DEFAULT_VMAX = 0.5  # Mach 0 constant-density default: v_max where the highest mode's k falls to this
REFINE_MIN = 2.0**-12  # smallest refinement step of the tracker, relative to the sweep's natural range
DEFAULT_ALTITUDE_RANGE_M = (0.0, 20_000.0)


@functools.lru_cache(maxsize=64)
def reference_state(altitude_m: float) -> tuple[float, float]:
    """(rho kg/m^3, a m/s) of the ISA at ``altitude_m`` (m), cached."""
    st = isa(altitude_m)
    return float(st.rho), float(st.a)


def resolve_reference(
    altitude_ref_m: float, rho_ref: float | None, a_ref: float | None
) -> tuple[float, float, float | None]:
    """(rho_ref, a_ref, altitude_ref_m or None when both were given explicitly)."""
    if rho_ref is not None and a_ref is not None:
        return finite_positive("rho_ref", rho_ref), finite_positive("a_ref", a_ref), None
    h = float(altitude_ref_m)
    ref_rho, ref_a = reference_state(h)
    rho = ref_rho if rho_ref is None else finite_positive("rho_ref", rho_ref)
    a = ref_a if a_ref is None else finite_positive("a_ref", a_ref)
    return rho, a, h


def default_v_max(omega: np.ndarray, c_ref: float, mach: float, a_ref: float) -> float:
    """Default end of a constant-density sweep (m/s).

    Mach > 0: 3 M a_ref. Mach 0 (incompressible, no speed of sound to scale with): the speed at which the
    highest structural mode's reduced frequency on the root semichord, k = omega_max (c_ref / 2) / V, has
    fallen to ``K_MIN_DEFAULT_VMAX`` = 0.5, i.e. V_max = omega_max c_ref. Flutter needs a structural branch
    whose frequency stays below about omega_max at a reduced frequency of order 0.1..1, so this covers it with
    margin (Goland wing, 4 modes: 637 m/s against its 166 m/s flutter speed).
    """
    if mach > 0:
        return 3.0 * mach * a_ref
    return float(np.max(omega)) * 0.5 * c_ref / K_MIN_DEFAULT_VMAX


@dataclass(frozen=True)
class Sweep:
    """A sweep p -> (V, rho); subclasses define ``cond``; p_start is q = 0, p_end the end of the range."""

    name: str
    p_start: float
    p_end: float
    rho_ref: float
    scale: float  # the sweep's natural range (its default p_end - p_start), independent of the user's range

    def cond(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(V [m/s], rho [kg/m^3]) at parameters p (array)."""
        raise NotImplementedError

    def grid(self, n: int) -> np.ndarray:
        """The coarse grid of n points (p_start excluded, p_end included)."""
        return np.linspace(self.p_start + (self.p_end - self.p_start) / n, self.p_end, n)

    def scale_at(self, p: float) -> float:
        """The natural range of the sweep parameter around p (independent of n_points and of the user's range)."""
        return self.scale

    def min_step(self, p: float) -> float:
        """Smallest step of the tracker's refinement at p: ``REFINE_MIN`` of the natural range."""
        return REFINE_MIN * self.scale_at(p)

    def start_points(self) -> np.ndarray:
        """Fixed points near q = 0 that every search tracks before its first grid point (ascending).

        p_start + 2^-8 ... 2^-3 of the natural range in doubling steps: so the first step from q = 0, which
        has no history to check it against, is the same whatever the number of grid points, and the steps
        that follow can be checked against the ones before.
        """
        return self.p_start + self.scale_at(self.p_start) * 2.0 ** -np.arange(8.0, 2.0, -1.0)

    def start_state_point(self) -> float:
        """p_start + 1e-6 of the natural range: the start state of a crossing bracket that begins at q = 0
        (a branch of zero structural damping has Re(s) = 0 exactly at q = 0)."""
        return self.p_start + 1e-6 * self.scale_at(self.p_start)

    def x(self, p: np.ndarray, v: np.ndarray, rho: np.ndarray) -> np.ndarray:
        """Continuation coordinate of the tracker's smoothness checks at p (flight condition v, rho): p itself."""
        return np.asarray(p, float)

    def speed_axis(self, v: np.ndarray, q: np.ndarray) -> np.ndarray:
        """The V-g plot's speed axis (true speed; constant-speed overrides)."""
        return v

    def altitude(self, p: np.ndarray) -> np.ndarray:
        """Altitude of each point (m; NaN unless matched)."""
        return np.full(np.shape(p), np.nan)

    def keep(self, p: np.ndarray) -> np.ndarray:
        """Points reported in the V-g data (the matched sweep's density ramp is not)."""
        return np.ones(np.shape(p), bool)

    def p_check(self, p_f: float, q_f: float, factor: float) -> float:
        """Parameter of the SDOFF check at ``factor`` x q_f."""
        raise NotImplementedError

    def range_text(self) -> str:
        """'no flutter up to ...' text."""
        raise NotImplementedError


@dataclass(frozen=True)
class ConstantDensity(Sweep):
    """p = V (m/s) at rho_ref."""

    def cond(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return np.asarray(p, float), np.full(np.shape(p), self.rho_ref)

    def p_check(self, p_f: float, q_f: float, factor: float) -> float:
        return p_f * math.sqrt(factor)

    def range_text(self) -> str:
        return f"V = {self.p_end:.6g} m/s"


@dataclass(frozen=True)
class ConstantSpeed(Sweep):
    """p = q (Pa) at V0 = M a_ref."""

    v0: float = 0.0

    def cond(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        p = np.asarray(p, float)
        return np.full(p.shape, self.v0), 2.0 * p / self.v0**2

    def speed_axis(self, v: np.ndarray, q: np.ndarray) -> np.ndarray:
        return np.sqrt(2.0 * q / self.rho_ref)

    def p_check(self, p_f: float, q_f: float, factor: float) -> float:
        return p_f * factor

    def range_text(self) -> str:
        return f"q = {self.p_end:.6g} Pa"


@dataclass(frozen=True)
class Matched(Sweep):
    """p in [-1, 0): density ramp at h_hi; p >= 0: altitude h_hi - p with V = M a(h)."""

    mach: float = 0.0
    h_lo: float = 0.0
    h_hi: float = 0.0
    v_top: float = 0.0
    rho_top: float = 0.0

    def cond(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        p = np.asarray(p, float)
        rho_h, a_h, _ = isa_table(self.h_hi - np.maximum(p, 0.0))
        v = np.where(p < 0, self.v_top, self.mach * a_h)
        rho = np.where(p < 0, self.rho_top * (1.0 + np.minimum(p, 0.0)), rho_h)
        return v, rho

    def grid(self, n: int) -> np.ndarray:
        return np.concatenate([np.linspace(-0.75, -0.25, 3), np.linspace(0.0, self.h_hi - self.h_lo, n)])

    def scale_at(self, p: float) -> float:
        return 1.0 if p < 0 else self.scale  # density ramp: p in [-1, 0)

    def start_points(self) -> np.ndarray:
        # the ramp's grid (-0.75, -0.5, -0.25) does not depend on n: one point makes the second step checkable
        return np.array([-1.0 + 2.0**-3])

    def x(self, p: np.ndarray, v: np.ndarray, rho: np.ndarray) -> np.ndarray:
        # q / q(h_top): linear along the ramp and smooth across its end (p itself has a kink there)
        return rho * v**2 / (self.rho_top * self.v_top**2)

    def altitude(self, p: np.ndarray) -> np.ndarray:
        p = np.asarray(p, float)
        return np.where(p >= 0.0, self.h_hi - p, np.nan)

    def keep(self, p: np.ndarray) -> np.ndarray:
        return np.asarray(p) >= 0.0

    def p_check(self, p_f: float, q_f: float, factor: float) -> float:
        from romams_core.atmosphere import altitude_for_dynamic_pressure

        h_chk = altitude_for_dynamic_pressure(q_f * factor, self.mach, clamp=True)
        return max(self.h_hi - h_chk, p_f)

    def range_text(self) -> str:
        return f"altitude down to {self.h_lo:.6g} m"


def make_sweep(
    name: str, mach: float, omega: np.ndarray, c_ref: float, rho_ref: float, a_ref: float,
    v_max: float | None, q_max: float | None, altitude_range_m: tuple[float, float],
) -> Sweep:
    """The sweep object of a search (ranges validated; InputError naming the field)."""
    if name == "constant-density":
        v_def = default_v_max(omega, c_ref, mach, a_ref)
        v_end = finite_positive("v_max", v_def if v_max is None else v_max)
        return ConstantDensity(name, 0.0, v_end, rho_ref, v_def)
    if name == "constant-speed":
        v0 = mach * a_ref
        q_def = 4.0 * 0.5 * rho_ref * v0**2
        q_end = q_def if q_max is None else finite_positive("q_max", q_max)
        return ConstantSpeed(name, 0.0, q_end, rho_ref, q_def, v0)
    try:
        h_lo, h_hi = (float(x) for x in altitude_range_m)
    except (TypeError, ValueError):
        raise InputError("altitude_range_m", f"must be (low, high) in m, got {altitude_range_m!r}") from None
    if not (math.isfinite(h_lo) and math.isfinite(h_hi) and h_lo < h_hi):
        raise InputError("altitude_range_m", f"must be (low, high) with low < high, got {altitude_range_m!r}")
    try:
        rho_top, a_top, _ = isa_table(h_hi)
        isa_table(h_lo)  # range check
    except InputError as exc:
        raise InputError("altitude_range_m", exc.reason) from None
    h_def = DEFAULT_ALTITUDE_RANGE_M[1] - DEFAULT_ALTITUDE_RANGE_M[0]
    return Matched(name, -1.0, h_hi - h_lo, rho_ref, h_def, mach, h_lo, h_hi, mach * float(a_top), float(rho_top))


def eas(q: np.ndarray) -> np.ndarray:
    """Equivalent airspeed sqrt(2 q / rho_0) (m/s) of dynamic pressures q (Pa), rho_0 the ISA sea-level density."""
    return np.sqrt(2.0 * np.asarray(q, float) / RHO_SEA_LEVEL)
