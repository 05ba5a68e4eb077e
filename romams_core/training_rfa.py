"""Training of a rational-function ROM from a frequency-domain solver (the DLM), once per Mach number.

The solver gives the generalized aerodynamic forces of the basis shapes, H(k) [nk, m, m] (m^3 per unit
generalized displacement, k = omega b / V on b = c_ref / 2) on a table of reduced frequencies; a Roger RFA
(``romams_core.rfa``) is fitted in basis coordinates and realized as a continuous state space in t* with the
damping and apparent-mass terms D1, D2. Every structure's modal ROM is then ``to_modal(rom.ss, gamma)``, as for
the time-domain (ARX) ROMs, and the flutter search couples it directly.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from romams_core.aero.protocol import ProgressFn, check_k_values
from romams_core.ct_reduction import balanced_realization, spa_reduce
from romams_core.errors import InputError
from romams_core.mesh import StandardMesh
from romams_core.rfa import (
    DEFAULT_MAX_LAGS,
    DEFAULT_TOL,
    RogerRfa,
    check_lag_settings,
    entry_scale,
    fit_errors,
    fit_rfa,
)
from romams_core.statespace import ContinuousSS
from romams_core.wing import SYMMETRIES

#: Default table of reduced frequencies (on the semichord): dense where the lag terms bend, to k = 2.
DEFAULT_K_VALUES = (0.0, 0.02, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.65, 0.8, 1.0, 1.25, 1.5, 1.75, 2.0)


@dataclass
class TrainedRfaRom:
    """A rational-function aerodynamic ROM at one Mach number (basis coordinates), with its table and fit errors."""

    solver: str
    mach: float
    c_ref: float  # m
    n_basis: int  # m, inputs = outputs
    k_values: np.ndarray  # [nk] reduced frequencies of the table
    gaf: np.ndarray  # [nk, m, m] solver GAF (m^3)
    rfa: RogerRfa
    ss: ContinuousSS  # continuous realization in t* (with D1, D2), reduced when asked (the model flutter uses)
    fit_error: np.ndarray  # [m, m] worst weighted error of ``ss`` over the table per entry (romams_core.rfa)
    fit_tol: float
    lag_counts: np.ndarray  # lag counts tried by the automatic choice
    lag_errors: np.ndarray  # worst entry error reached with each count
    warnings: list[str] = field(default_factory=list)
    train_seconds: float = 0.0
    solver_seconds: float = 0.0
    solver_description: str = ""
    n_states_full: int = 0  # states of the RFA's realization before the balanced reduction
    hsv: np.ndarray = field(default_factory=lambda: np.zeros(0))  # Hankel singular values of that realization

    @property
    def n_lags(self) -> int:
        """Number of lag roots of the RFA."""
        return self.rfa.n_lags

    @property
    def k_max(self) -> float:
        """Top of the fitted band: the table's largest reduced frequency (on the semichord)."""
        return float(self.k_values[-1])

    @property
    def max_fit_error(self) -> float:
        """Worst weighted entry error of the fit over the table."""
        return float(np.max(self.fit_error))

    @property
    def validation_nrmse(self) -> np.ndarray:
        """Per-output quality number shown next to the ARX ROMs' validation NRMSE: worst fit error of each row."""
        return np.max(self.fit_error, axis=1)

    @property
    def na(self) -> int:
        """ARX order (none: a frequency-domain ROM)."""
        return 0

    @property
    def nb(self) -> int:
        """ARX order (none: a frequency-domain ROM)."""
        return 0

    def summary(self) -> dict[str, object]:
        """Small JSON-able summary (floats and lists)."""
        return {
            "solver": self.solver,
            "kind": "rfa",
            "mach": self.mach,
            "n_basis": self.n_basis,
            "n_lags": self.n_lags,
            "lags": [float(x) for x in self.rfa.lags],
            "n_states": self.ss.n_states,
            "n_states_full": self.n_states_full,
            "k_max": self.k_max,
            "n_k": int(self.k_values.size),
            "fit_error_max": self.max_fit_error,
            "validation_nrmse": [float(x) for x in self.validation_nrmse],
            "train_seconds": self.train_seconds,
            "warnings": list(self.warnings),
        }


#: Lattice refinements a DLM training may ask for (``lattice_refine``; the solver's default is 2).
LATTICE_REFINES = (1, 2, 3, 4)


def check_rfa_settings(k_values: Any = DEFAULT_K_VALUES, n_lags: Any = None, max_lags: Any = DEFAULT_MAX_LAGS,
                       fit_tol: Any = DEFAULT_TOL, reduce_order: Any = None,
                       lattice_refine: Any = None, symmetry: Any = None) -> np.ndarray:
    """Validated settings of :func:`train_rfa_rom` (InputError naming the setting); returns the k table.

    The one check of these settings: the training calls it before its solver runs, and the service before it
    queues a training job.
    """
    k = check_k_values(k_values)
    if k.size < 4:
        raise InputError("k_values", f"need at least 4 reduced frequencies for the RFA, got {k.size}")
    check_lag_settings(n_lags, max_lags, fit_tol, tol_field="fit_tol")
    if not (reduce_order is None or reduce_order == "auto"
            or (isinstance(reduce_order, int | np.integer) and not isinstance(reduce_order, bool)
                and reduce_order >= 0)):
        raise InputError("reduce_order", f"must be 'auto', an integer >= 0 or None, got {reduce_order!r}")
    if lattice_refine is not None and (isinstance(lattice_refine, bool) or lattice_refine not in LATTICE_REFINES):
        raise InputError("lattice_refine", f"must be one of {', '.join(map(str, LATTICE_REFINES))} or None (the "
                         f"solver's default), got {lattice_refine!r}")
    if symmetry is not None and symmetry not in SYMMETRIES:
        raise InputError("symmetry", f"must be one of {', '.join(SYMMETRIES)} or None, got {symmetry!r}")
    return k


def train_rfa_rom(
    mesh: StandardMesh,
    shapes: np.ndarray,
    mach: float,
    solver: Any,
    *,
    k_values: Any = DEFAULT_K_VALUES,
    n_lags: int | None = None,
    max_lags: int = DEFAULT_MAX_LAGS,
    fit_tol: float = DEFAULT_TOL,
    reduce_order: int | str | None = None,
    lattice_refine: int | None = None,
    symmetry: str | None = None,
    progress: ProgressFn | None = None,
) -> TrainedRfaRom:
    """GAF table of ``shapes`` [N, m] (m) by the frequency-domain ``solver`` at ``mach`` and its Roger RFA.

    ``k_values``: reduced frequencies (semichord) of the table; include 0 so the steady term is exact.
    ``n_lags``/``max_lags``/``fit_tol`` go to ``romams_core.rfa.fit_rfa``. ``reduce_order``: None (default) keeps the
    realization; "auto" reduces it by balanced singular perturbation (``romams_core.ct_reduction``) to the fewest
    states whose error stays within the fit's (:func:`reduce_model`), an integer to that order. Not the default:
    on the cropped delta (20 designs x 5 Machs) "auto" cut the states by 20-40 % and the flutter time by about
    30 %, but moved ROM-AMS from 0.45 % to 1.41 % of ROM-PMS (docs/aerodynamics.md, section 12.2).
    ``lattice_refine``: boxes per standard-mesh panel edge of a lattice solver (``DlmSolver.refine``); None keeps
    the solver's. 1 trains about 7x faster than the default 2 (cropped delta, 8 shapes, 16 k: 3 s against 20 s)
    at 8.5-9.4 % GAF error against the 4x lattice (2: 2.9-3.3 %): for smoke runs and tests of everything but
    the lattice's accuracy.
    ``symmetry``: the root plane's (symmetric, antisymmetric, none: a free wing) for a solver that models it
    (``DlmSolver.symmetry``); None keeps the solver's.
    ``progress(fraction, message)``
    follows the solver (90 %) and the fit; a ``Cancelled`` raised by it propagates.
    """
    t0 = time.perf_counter()
    k = check_rfa_settings(k_values, n_lags, max_lags, fit_tol, reduce_order, lattice_refine, symmetry)
    for key, value in (("refine", lattice_refine), ("symmetry", symmetry)):  # the solver's own settings
        if value is not None:
            if not hasattr(solver, key):
                raise InputError("lattice_refine" if key == "refine" else key,
                                 f"solver {solver.name!r} has no setting {key!r}")
            solver = dataclasses.replace(solver, **{key: value})

    def solver_progress(frac: float, msg: str) -> None:
        if progress is not None:
            progress(0.9 * frac, msg)

    gaf = np.asarray(solver.gaf(mesh, shapes, mach, k, progress=solver_progress), dtype=complex)
    t_solver = time.perf_counter() - t0
    if progress is not None:
        progress(0.9, "fitting the rational function approximation")
    fit = fit_rfa(k, gaf, n_lags=n_lags, max_lags=max_lags, tol=fit_tol)
    full = fit.rfa.state_space()
    ss, hsv = reduce_model(full, k, gaf, fit.max_error, fit_tol, reduce_order)
    fit_error = fit_errors(ss.freqresp(k), gaf, entry_scale(gaf))
    warnings = list(solver.info(mach).warnings)
    if fit.max_error > fit_tol:
        warnings.append(f"RFA fit error {fit.max_error:.3g} above the tolerance {fit_tol:g} with "
                        f"{fit.rfa.n_lags} lag(s)")
    if k[0] > 0.0:
        warnings.append("the table has no k = 0 point: the steady term is fitted, not exact")
    counts = np.array(sorted(fit.errors_by_lags), dtype=int)
    rom = TrainedRfaRom(
        solver=str(solver.name), mach=float(mach), c_ref=float(mesh.c_ref), n_basis=int(gaf.shape[1]),
        k_values=k, gaf=gaf, rfa=fit.rfa, ss=ss, fit_error=fit_error, fit_tol=float(fit_tol),
        lag_counts=counts, lag_errors=np.array([fit.errors_by_lags[int(c)] for c in counts]), warnings=warnings,
        train_seconds=time.perf_counter() - t0, solver_seconds=t_solver,
        solver_description=solver.info(mach).description, n_states_full=full.n_states, hsv=hsv,
    )
    if progress is not None:
        progress(1.0, f"RFA with {fit.rfa.n_lags} lag(s), worst entry error {fit.max_error:.2e}")
    return rom


def reduce_model(full: ContinuousSS, k: np.ndarray, gaf: np.ndarray, fit_error: float, tol: float,
                 reduce_order: int | str | None) -> tuple[ContinuousSS, np.ndarray]:
    """(model, Hankel singular values): the RFA realization reduced as ``reduce_order`` asks (train_rfa_rom).

    "auto": the smallest order whose worst weighted entry error against the solver's table is within
    max(tol, 1.1 x the full fit's) and whose deviation from the full RFA on a fine grid (to 1.25 k_max) is below
    tol / 2 (no wiggles between the table's points).
    """
    if reduce_order is None or full.n_states == 0:
        return full, np.zeros(0)
    bal, hsv = balanced_realization(full)
    if reduce_order != "auto":  # an integer (check_rfa_settings)
        return spa_reduce(bal, int(min(int(reduce_order), bal.n_states))), hsv
    scale = entry_scale(gaf)
    fine = np.linspace(0.0, 1.25 * float(k[-1]), 41)
    ref = full.freqresp(fine)
    limit = max(tol, 1.1 * fit_error)
    for order in range(1, bal.n_states):  # at most a few tens of small frequency responses
        red = spa_reduce(bal, order)
        if not red.is_stable():
            continue
        if (np.max(fit_errors(red.freqresp(k), gaf, scale)) <= limit
                and np.max(fit_errors(red.freqresp(fine), ref, scale)) <= 0.5 * tol):
            return red, hsv
    return bal, hsv
