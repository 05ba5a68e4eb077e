"""International Standard Atmosphere (wrapper around the ``ambiance`` package).

All inputs and outputs are SI: geometric altitude h in m, density in kg/m^3, speed of sound in m/s,
temperature in K, pressure in Pa, dynamic pressure in Pa. The valid altitude range is that of
``ambiance`` (about -5 km to 81 km); outside it the functions raise InputError (a ValueError) unless ``clamp`` is set.

The flight dynamic pressure at Mach M is q = 0.5 rho (M a)^2 = 0.5 gamma p M^2 (gamma = 1.4, since
a^2 = gamma p / rho), so the altitude for a given (q, M) follows from the static pressure alone.

``isa`` calls ambiance directly (about 0.3 ms per call). The hot paths (matched flutter sweeps, the
envelope) use ``isa_table``: ambiance sampled once every 10 m plus the layer boundaries, interpolated
linearly in (log p, log rho, a). Within a layer ln p, ln rho and a are smooth in h, so the error is below
1e-7 relative (about 1 mm in an inverted altitude); within 10 m of a layer boundary it reaches a few 1e-6,
the size of the jump in ambiance's own tabulated base pressures there. Tests check it against ambiance.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from ambiance import Atmosphere

from romams_core.errors import InputError
from romams_core.validation import check_number

GAMMA_AIR = 1.4
H_MIN_M = -5004.0  # ambiance's lower limit (m); hard-coded so as not to depend on its internals
H_MAX_M = 81020.0  # ambiance's upper limit (m)
_P_AT_H_MIN = float(Atmosphere(H_MIN_M).pressure[0])
_P_AT_H_MAX = float(Atmosphere(H_MAX_M).pressure[0])
RHO_SEA_LEVEL = float(Atmosphere(0.0).density[0])  # ISA sea-level density rho_0 (1.225 kg/m^3), for EAS


@dataclass(frozen=True)
class AtmosphereState:
    """ISA state at altitude(s): h (m), rho (kg/m^3), a (m/s), temperature (K), pressure (Pa)."""

    altitude_m: np.ndarray
    rho: np.ndarray
    a: np.ndarray
    temperature: np.ndarray
    pressure: np.ndarray


def _check_altitude(h: float | np.ndarray, clamp: bool, name: str = "altitude_m") -> np.ndarray:
    """Validate/clamp altitudes (m) against the table range of ambiance."""
    h = np.asarray(h, dtype=float)
    if not np.all(np.isfinite(h)):
        raise InputError(name, f"must be finite, got {h!r}")
    if clamp:
        return np.clip(h, H_MIN_M, H_MAX_M)
    if np.any(h < H_MIN_M) or np.any(h > H_MAX_M):
        raise InputError(name, f"outside the standard atmosphere range [{H_MIN_M:g}, {H_MAX_M:g}] m, got {h!r}")
    return h


def isa(altitude_m: float | np.ndarray, clamp: bool = False) -> AtmosphereState:
    """ISA state at geometric altitude(s) ``altitude_m`` (m); arrays keep the input shape."""
    h = _check_altitude(altitude_m, clamp)
    flat = np.atleast_1d(h).ravel()
    atm = Atmosphere(flat)
    shape = h.shape

    def _r(v: np.ndarray) -> np.ndarray:
        return np.asarray(v, dtype=float).reshape(shape)

    return AtmosphereState(h.copy(), _r(atm.density), _r(atm.speed_of_sound), _r(atm.temperature), _r(atm.pressure))


def density(altitude_m: float, clamp: bool = False) -> float:
    """Air density (kg/m^3) at altitude ``altitude_m`` (m)."""
    return float(isa(altitude_m, clamp).rho)


def speed_of_sound(altitude_m: float, clamp: bool = False) -> float:
    """Speed of sound (m/s) at altitude ``altitude_m`` (m)."""
    return float(isa(altitude_m, clamp).a)


def flight_dynamic_pressure(mach: float, altitude_m: float | np.ndarray, clamp: bool = False) -> np.ndarray | float:
    """Dynamic pressure q = 0.5 rho (M a)^2 = 0.5 gamma p M^2 (Pa) at Mach ``mach`` and altitude(s) (m), tabulated."""
    check_number("mach", mach, 0.0)
    _, _, p = isa_table(altitude_m, clamp)
    q = 0.5 * GAMMA_AIR * p * mach**2
    return float(q) if np.ndim(q) == 0 else q


def altitude_for_dynamic_pressure(q_pa: float, mach: float, clamp: bool = False) -> float:
    """Geometric altitude (m) where 0.5 rho(h) (M a(h))^2 equals ``q_pa`` (Pa) at Mach ``mach``.

    The static pressure there is p = q / (0.5 gamma M^2). With ``clamp`` a q above the value at the
    lowest table altitude returns that altitude (-5004 m) and a q below the value at the top returns
    the top (81020 m); without it such a q raises ValueError.
    """
    check_number("mach", mach, 0.0)
    check_number("q_pa", q_pa, 0.0)
    p = float(q_pa) / (0.5 * GAMMA_AIR * mach * mach)
    if p > _P_AT_H_MIN or p < _P_AT_H_MAX:
        if not clamp:
            raise InputError(
                "q_pa", f"{q_pa:g} Pa at Mach {mach:g} needs static pressure {p:g} Pa, outside the standard "
                f"atmosphere range [{_P_AT_H_MAX:g}, {_P_AT_H_MIN:g}] Pa"
            )
        return H_MIN_M if p > _P_AT_H_MIN else H_MAX_M
    return float(altitude_for_pressure(p))


_R0_M = 6356766.0  # ISA earth radius for geopotential altitude (m)
_LAYER_GEOPOTENTIAL_M = (0.0, 11000.0, 20000.0, 32000.0, 47000.0, 51000.0, 71000.0)


@functools.lru_cache(maxsize=1)
def _table() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(h m, ln p, ln rho, a) sampled every 10 m and at the ISA layer boundaries (built once)."""
    bounds = np.array([_R0_M * hg / (_R0_M - hg) for hg in _LAYER_GEOPOTENTIAL_M])
    h = np.unique(np.concatenate([np.arange(H_MIN_M, H_MAX_M, 10.0), [H_MAX_M], bounds]))
    atm = Atmosphere(h)
    return h, np.log(atm.pressure), np.log(atm.density), np.asarray(atm.speed_of_sound, dtype=float)


def isa_table(altitude_m: float | np.ndarray, clamp: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fast tabulated ISA (rho kg/m^3, a m/s, p Pa) at altitude(s) (m); within 1e-7 of ``isa``."""
    h = _check_altitude(altitude_m, clamp)
    th, lp, lr, ta = _table()
    return np.exp(np.interp(h, th, lr)), np.interp(h, th, ta), np.exp(np.interp(h, th, lp))


def altitude_for_pressure(p_pa: float | np.ndarray) -> np.ndarray:
    """Geometric altitude (m) of static pressure(s) p (Pa) by inverting the table (clamped to its range)."""
    th, lp, _, _ = _table()
    return np.interp(-np.log(np.asarray(p_pa, dtype=float)), -lp, th)
