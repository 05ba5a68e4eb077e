"""Generic input checks of the numerical core; each raises :class:`romams_core.errors.InputError` naming the input.

``field`` is the dotted name of the input as the caller knows it (``"mach"``, ``"planform.root_chord"``,
``"aero.dt_star"``); the message is ``"<field>: <reason>"``. Module-specific checks (an ISA altitude range,
aero-model shapes) live next to the code they protect but raise the same error type.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from romams_core.errors import InputError

__all__ = [
    "InputError",
    "check_choice",
    "check_finite_array",
    "check_int",
    "check_number",
    "check_unit_interval",
    "finite_positive",
]

_REAL = (int, float, np.integer, np.floating)


def check_number(
    field: str,
    value: Any,
    lower: float | None = None,
    *,
    strict: bool = True,
    upper: float | None = None,
    upper_strict: bool = True,
) -> float:
    """``value`` as float, or InputError unless it is a finite real number within the given bounds.

    ``lower`` / ``upper`` are exclusive when ``strict`` / ``upper_strict`` (default), else inclusive. Booleans
    and non-numeric types (strings, arrays) are refused.
    """
    if isinstance(value, bool) or not isinstance(value, _REAL):
        raise InputError(field, f"must be a number, got {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise InputError(field, f"must be a finite number, got {value!r}")
    if lower is not None and not (v > lower if strict else v >= lower):
        raise InputError(field, f"must be {'>' if strict else '>='} {lower:g}, got {value!r}")
    if upper is not None and not (v < upper if upper_strict else v <= upper):
        raise InputError(field, f"must be {'<' if upper_strict else '<='} {upper:g}, got {value!r}")
    return v


def finite_positive(field: str, value: Any) -> float:
    """``value`` as float (anything ``float()`` accepts), or InputError unless finite and > 0."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(field, f"must be a number, got {value!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise InputError(field, f"must be a finite number > 0, got {value!r}")
    return v


def check_int(field: str, value: Any, lower: int, upper: int) -> int:
    """``value`` as int, or InputError unless it is an integer (not a bool) in [lower, upper]."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or not lower <= int(value) <= upper:
        raise InputError(field, f"must be an integer in [{lower}, {upper}], got {value!r}")
    return int(value)


def check_unit_interval(field: str, value: Any) -> float:
    """``value`` as float, or InputError unless it is a number in the open interval (0, 1)."""
    if isinstance(value, bool) or not isinstance(value, _REAL) or not 0.0 < float(value) < 1.0:
        raise InputError(field, f"must be a number in (0, 1), got {value!r}")
    return float(value)


def check_choice(field: str, value: Any, choices: Sequence[str]) -> str:
    """``value`` if it is one of ``choices``, else InputError listing them."""
    if not isinstance(value, str) or value not in choices:
        raise InputError(field, f"must be one of {tuple(choices)}, got {value!r}")
    return value


def check_finite_array(field: str, value: Any, ndim: int | None = None) -> np.ndarray:
    """``value`` as a float array, or InputError unless numeric, finite and (if given) of ``ndim`` dimensions."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(field, "must be a numeric array") from None
    if ndim is not None and arr.ndim != ndim:
        raise InputError(field, f"expected a {ndim}-D array, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(field, "contains NaN or infinite values")
    return arr
