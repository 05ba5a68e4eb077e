"""The one interface every unsteady aerodynamic solver ("CFD") implements.

Conventions of ``simulate`` (shared by the built-in UVLM, a transonic solver and external-CFD adapters):
- ``shapes`` [N, m]: out-of-plane (+z) displacement of the standard-mesh nodes per unit generalized
  coordinate (m);
- ``signals`` [T, m]: generalized displacements u_i (dimensionless) sampled on the nondimensional time
  grid t*_n = n * dt_star, t* = t V / c_ref, starting from rest (u = 0 before n = 0);
- returns ``gac`` [T, m]: generalized aerodynamic coefficients f_i(t_n) = (1/q) * integral(dp * phi_i dS)
  (m^3 when shapes are in m), dp positive up, q = rho V^2 / 2.

Frequency-domain solvers (``FrequencySolver.gaf``) return the harmonic counterpart: the complex GAC matrix
H [nk, m, m] (m^3), H[k, i, j] = f_i per unit harmonic u_j (u = u_hat e^{i omega t}), at reduced frequencies
k = omega b / V on b = c_ref / 2, with the same f_i and shapes as above.

Nothing above this interface may depend on a particular solver's internals.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np

from romams_core.errors import InputError
from romams_core.mesh import StandardMesh
from romams_core.wing import SYMMETRIES

ProgressFn = Callable[[float, str], None]

#: Above this Mach number linear (Prandtl-Glauert) compressibility corrections are flagged unreliable.
LINEAR_MACH_WARNING = 0.9


class Cancelled(Exception):
    """Raised by a progress callback to cancel a running simulation; solvers let it propagate."""


@dataclass
class SolverInfo:
    """What a solver is and the caveats of its results at one Mach number (warnings are plain strings)."""

    name: str
    description: str
    warnings: list[str] = field(default_factory=list)


@runtime_checkable
class UnsteadySolver(Protocol):
    """Time-domain unsteady aerodynamic solver driven by generalized displacements of given shapes."""

    name: str

    def simulate(
        self,
        mesh: StandardMesh,
        shapes: np.ndarray,
        signals: np.ndarray,
        mach: float,
        dt_star: float,
        progress: ProgressFn | None = None,
    ) -> np.ndarray:
        """Run the solver for signals [T, m] of shapes [N, m] (m) at ``mach``; return GAC [T, m] (m^3)."""
        ...

    def info(self, mach: float) -> SolverInfo:
        """Describe the solver and list warnings that apply to results at ``mach``."""
        ...


@runtime_checkable
class RecordsSolver(Protocol):
    """A time-domain solver that runs several independent records, each from rest, in one call (side by side).

    Training then runs its training and validation signals as two records instead of one continued run, and
    validates the model from rest on the validation signal.
    """

    def simulate_records(
        self,
        mesh: StandardMesh,
        shapes: np.ndarray,
        records: list[np.ndarray],
        mach: float,
        dt_star: float,
        progress: ProgressFn | None = None,
    ) -> list[np.ndarray]:
        """GAC [T_r, m] (m^3) of shapes [N, m] (m) for each record [T_r, m] of signals, every one from rest."""
        ...


@runtime_checkable
class FrequencySolver(Protocol):
    """Frequency-domain unsteady aerodynamic solver: harmonic GAC of given shapes at reduced frequencies."""

    name: str

    def gaf(
        self,
        mesh: StandardMesh,
        shapes: np.ndarray,
        mach: float,
        k_values: np.ndarray,
        progress: ProgressFn | None = None,
    ) -> np.ndarray:
        """Complex GAC H [nk, m, m] (m^3) of shapes [N, m] (m) at reduced frequencies k = omega c_ref / (2 V)."""
        ...

    def info(self, mach: float) -> SolverInfo:
        """Describe the solver and list warnings that apply to results at ``mach``."""
        ...


def check_mach(mach: float, upper: float = 0.999) -> float:
    """Validate a free-stream Mach number (0 <= M < upper); return it as float."""
    if not (isinstance(mach, int | float | np.floating | np.integer) and math.isfinite(mach)):
        raise InputError("mach", f"must be a finite number, got {mach!r}")
    if not 0.0 <= float(mach) < upper:
        raise InputError("mach", f"must be in [0, {upper}) for this solver, got {mach}")
    return float(mach)


#: the mirror image's loading sign of each root symmetry (``romams_core.wing.SYMMETRIES``): symmetric +1,
#: antisymmetric -1, none (a free wing) 0; the DLM's image boxes and the UVLM's image rings and wake carry it
IMAGE_SIGN = dict(zip(SYMMETRIES, (1.0, -1.0, 0.0), strict=True))


def image_sign(symmetry: str) -> float:
    """+1, -1 or 0 (dimensionless) for a symmetric, antisymmetric or free (no mirror) wing (InputError naming
    ``symmetry``)."""
    if symmetry not in IMAGE_SIGN:
        raise InputError("symmetry", f"must be one of {tuple(IMAGE_SIGN)}, got {symmetry!r}")
    return IMAGE_SIGN[symmetry]


def check_dt_star(dt_star: float) -> float:
    """Validate the nondimensional time step (t* = t V / c_ref); return it as float."""
    if not (isinstance(dt_star, int | float | np.floating | np.integer) and math.isfinite(dt_star) and dt_star > 0):
        raise InputError("dt_star", f"must be a finite number > 0, got {dt_star!r}")
    return float(dt_star)


def check_k_values(k_values: np.ndarray) -> np.ndarray:
    """Validate reduced frequencies (1-D, non-empty, finite, >= 0, strictly ascending); return a float array."""
    try:
        arr = np.asarray(k_values, dtype=float)
    except (TypeError, ValueError):
        raise InputError("k_values", f"must be an array of numbers, got {k_values!r}") from None
    if arr.ndim != 1 or arr.size == 0:
        raise InputError("k_values", f"must be a non-empty 1-D array, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError("k_values", "must be finite")
    if np.any(arr < 0.0):
        raise InputError("k_values", f"must be >= 0, got {arr.min()!r}")
    if np.any(np.diff(arr) <= 0.0):
        raise InputError("k_values", "must be strictly ascending")
    return arr


def check_shapes(mesh: StandardMesh, shapes: np.ndarray) -> np.ndarray:
    """Validate mode shapes [N, m] (m) against the mesh; a 1-D array is one shape. Returns float [N, m]."""
    arr = np.asarray(shapes, dtype=float)
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim != 2 or arr.shape[0] != mesh.n_nodes or arr.shape[1] < 1:
        raise InputError("shapes", f"expected shape [{mesh.n_nodes}, m>=1] (one column per shape), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError("shapes", "must be finite")
    return arr


def check_signals(signals: np.ndarray, m: int) -> np.ndarray:
    """Validate generalized-displacement signals [T, m]; return float [T, m]."""
    arr = np.asarray(signals, dtype=float)
    if arr.ndim == 1 and m == 1:
        arr = arr[:, None]
    if arr.ndim != 2 or arr.shape[1] != m or arr.shape[0] < 2:
        raise InputError("signals", f"expected shape [T>=2, {m}] (one column per shape), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError("signals", "must be finite")
    return arr


def mach_warnings(mach: float) -> list[str]:
    """Standard warning list for linear (Prandtl-Glauert corrected) solvers at ``mach``."""
    if mach > LINEAR_MACH_WARNING:
        return [
            f"M = {mach:.3f} > {LINEAR_MACH_WARNING}: the linear Prandtl-Glauert compressibility correction "
            "is unreliable toward M = 1 (no shocks, no transonic dip); use a transonic solver"
        ]
    return []
