"""Training of an aerodynamic ROM at one Mach number: excite shapes, run the solver once, identify ARX.

The ROM lives in the coordinates of the shapes it was trained on (basis shapes for ROM-AMS, a structure's
own modes for ROM-PMS), in nondimensional time t* = t V / c_ref with step dt_star; its outputs are the
generalized aerodynamic coefficients f = Q / q (m^3 with shapes in m, or m^2 per unit shape norm for
dimensionless orthonormal basis shapes).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from romams_core.aero.protocol import (
    ProgressFn,
    RecordsSolver,
    UnsteadySolver,
    check_dt_star,
    check_mach,
    check_shapes,
    image_sign,
)
from romams_core.arx import ArxModel, out_of_band_share
from romams_core.arx_identification import (
    Fit,
    Records,
    TrainingError,
    identify,
    minimal_arx_realization,
    record_error,
)
from romams_core.errors import InputError
from romams_core.mesh import StandardMesh
from romams_core.signals import excitation_signals
from romams_core.statespace import DiscreteSS, arx_to_ss
from romams_core.validation import check_number

__all__ = ["TrainedRom", "TrainingError", "train_rom", "default_n_steps", "with_minimal_realization"]

@dataclass
class TrainedRom:
    """An identified aerodynamic ROM at one Mach number, with its training data and diagnostics."""

    solver: str
    mach: float
    dt_star: float
    c_ref: float  # m
    n_basis: int  # m, inputs = outputs
    na: int
    nb: int
    k_max: float
    seed: int
    ridge: float
    arx: ArxModel
    ss: DiscreteSS  # model used downstream (reduced when asked), basis coordinates, t* step dt_star
    n_states_full: int  # states of the ARX realization before reduction
    hsv: np.ndarray  # Hankel singular values of the full realization ([] when not reduced)
    signals_train: np.ndarray  # [T, m]
    signals_validation: np.ndarray  # [T, m]
    gac_train: np.ndarray  # [T, m] solver output
    gac_validation: np.ndarray  # [T, m] solver output
    predicted_validation: np.ndarray  # [T, m] ROM (ss) output on the validation signal
    training_nrmse: np.ndarray  # [m] ARX free-run on the training signal
    validation_nrmse: np.ndarray  # [m] ss free-run on the validation signal
    arx_validation_nrmse: np.ndarray  # [m] unreduced ARX on the validation signal
    spectral_radius: float
    nrmse_tol: float
    warnings: list[str] = field(default_factory=list)
    train_seconds: float = 0.0
    solver_seconds: float = 0.0
    ar_ridge: float = 0.0  # AR-only regularization used (0 unless the plain fit was unstable)
    mean_flow: dict | None = None  # transonic solvers: the steady mean flow (surface Cp, convergence history)
    linearity_error: float | None = None  # transonic solvers: |2 GAC(u/2) - GAC(u)| / |GAC(u)| when checked
    anchor_k: np.ndarray | None = None  # reduced frequencies of direct solver runs the ss reproduces (anchors)
    anchor_gaf: np.ndarray | None = None  # [n_k, m, m] complex: the solver's transfer matrix there (m^3 per unit)
    anchor_band_error: float | None = None  # anchored: worst error against the direct runs over a k band (share)
    anchor_band_k: np.ndarray | None = None  # that band's reduced frequencies
    anchor_band_gaf: np.ndarray | None = None  # [n_band, m, m] complex: the direct transfer matrix there (m^3)
    validation_band: float | None = None  # the NRMSEs count k <= this only (None: the whole record)
    validation_distortion: np.ndarray | None = None  # [m] RMS share of the validation GAC above validation_band

    def validation_error(self, predicted: np.ndarray) -> np.ndarray:
        """Validation NRMSE [m] of a model's output on the validation signal, counted as this ROM's are."""
        return record_error(self.gac_validation, predicted, self.dt_star, self.validation_band)

    def summary(self) -> dict[str, object]:
        """Small JSON-able summary (floats and lists)."""
        return {
            "solver": self.solver,
            "mach": self.mach,
            "dt_star": self.dt_star,
            "n_basis": self.n_basis,
            "na": self.na,
            "nb": self.nb,
            "n_states": self.ss.n_states,
            "n_states_full": self.n_states_full,
            "validation_nrmse": [float(x) for x in self.validation_nrmse],
            "spectral_radius": self.spectral_radius,
            "train_seconds": self.train_seconds,
            "warnings": list(self.warnings),
            **({"mean_flow_converged": self.mean_flow.get("steady_converged"),
                "mean_flow_steps": self.mean_flow.get("steady_steps")} if self.mean_flow else {}),
            **({"linearity_error": self.linearity_error} if self.linearity_error is not None else {}),
            **({"anchor_k": [float(k) for k in self.anchor_k]} if self.anchor_k is not None else {}),
            **({"anchor_band_error": self.anchor_band_error} if self.anchor_band_error is not None else {}),
            **({"validation_band": self.validation_band} if self.validation_band is not None else {}),
            **({"validation_distortion": [float(x) for x in self.validation_distortion]}
               if self.validation_distortion is not None else {}),
        }


def check_validation_band(value: Any, k_max: float) -> None:
    """Validate ``validation_band``: None (the whole record) or a reduced frequency >= k_max (InputError naming it)."""
    if value is not None:
        check_number("validation_band", value, float(k_max), strict=False)


#: above this RMS share of the validation GAC outside the validation band, the ROM says so in its warnings
DISTORTION_WARN = 0.02


def default_n_steps(n_inputs: int, na: int, nb: int, dt_star: float, k_max: float) -> int:
    """Signal length (steps): >= 16 samples per ARX parameter per output, >= 200 t*, even."""
    n = max(
        16 * n_inputs * (na + nb),
        int(math.ceil(200.0 / dt_star)),
        int(math.ceil(40.0 * math.pi / (k_max * dt_star))),
    )
    return n + (n % 2)


def train_rom(
    mesh: StandardMesh,
    shapes: np.ndarray,
    mach: float,
    solver: UnsteadySolver,
    na: int = 8,
    nb: int = 8,
    k_max: float = 1.5,
    n_steps: int | None = None,
    dt_star: float | None = None,
    seed: int = 0,
    nrmse_tol: float = 0.02,
    ridge: float = 0.0,
    reduce_order: int | str | None = "auto",
    hsv_tol: float | None = None,
    reduce_tol: float = 0.002,
    progress: ProgressFn | None = None,
    displacement_fraction: float = 0.01,
    order_fallbacks: tuple[tuple[int, int], ...] = (),
    symmetry: str | None = None,
    low_k_corner: float = 0.0,
    validation_band: float | None = None,
) -> TrainedRom:
    """Identify an ARX ROM of ``solver`` for shapes [N, m] (m) at ``mach``; one solver run trains and validates.

    Signals: one band-limited (0 < k <= k_max on the root semichord) uncorrelated signal per shape, peak
    surface displacement ``displacement_fraction`` of c_ref (1 %); run as [train | validation] in one call, or as
    two records from rest side by side by a ``RecordsSolver``.
    The ARX (orders na, nb, ridge)
    is fitted on the training half and checked in free run on the validation half: any output with NRMSE
    > nrmse_tol raises TrainingError naming it, as does a model that cannot be stabilized (unstable, unexcited
    ARX poles are reflected into the unit circle, with a warning). Reduction (default "auto"; None keeps the
    full ARX realization): ``reduce_order`` = an int or ``hsv_tol`` (plain balanced truncation), or "auto":
    the smallest order (steps of m) of a frequency-limited
    balanced truncation (|k| <= k_max) that is stable and keeps every validation NRMSE <= ``reduce_tol``
    (falls back to the full model). The reduced model must meet nrmse_tol too. Default dt_star = 1 / n_chord.
    ``order_fallbacks``: further (na, nb) tried in turn on the same records when (na, nb) misses nrmse_tol; the
    first that meets it is kept (with a note), else the error names the best one.
    ``symmetry``: the root plane's (symmetric, antisymmetric, none: a free wing) for a solver that models it
    (``UvlmSolver.symmetry``, ``TsdSolver.symmetry``); None keeps the solver's.
    ``low_k_corner``: signal power raised as 1 / k below this reduced frequency (``signals.multisine``; 0 flat).
    ``validation_band`` (>= k_max; None: the whole record): every NRMSE (acceptance, reduction, stabilization)
    counts the records' parts at k <= it only (``arx.band_nrmse``), and the ROM keeps the validation GAC's RMS share
    above it (``validation_distortion``, a warning above ``DISTORTION_WARN``): with an input band-limited to k_max,
    that share is response no linear model of the input gives (measured on the TSD at M 0.96 on the AGARD grid
    x 1.5: 4-17 % near k 14, the same share at half the amplitude; docs/transonic.md 7.21).
    """
    t_start = time.perf_counter()
    mach = check_mach(mach)
    solver = with_symmetry(solver, symmetry)
    shapes = check_shapes(mesh, shapes)
    dt_star = check_dt_star(1.0 / mesh.n_chord if dt_star is None else dt_star)
    if not (math.isfinite(nrmse_tol) and nrmse_tol > 0):
        raise InputError("nrmse_tol", f"must be a finite number > 0, got {nrmse_tol!r}")
    check_validation_band(validation_band, k_max)
    if isinstance(reduce_order, str) and reduce_order != "auto":  # before the solver run
        raise InputError("reduce_order", f"must be an integer, 'auto' or None, got {reduce_order!r}")
    m = shapes.shape[1]
    if n_steps is None:
        n_steps = default_n_steps(m, na, nb, dt_star, k_max)
    if not (isinstance(n_steps, int | np.integer) and n_steps >= 16):
        raise InputError("n_steps", f"must be an integer >= 16, got {n_steps!r}")
    exc = excitation_signals(shapes, mesh.c_ref, int(n_steps), dt_star, k_max=k_max, seed=seed,
                             displacement_fraction=displacement_fraction, low_k_corner=low_k_corner)

    t_solver = time.perf_counter()
    both = Records(exc.train, exc.validation, continued=not isinstance(solver, RecordsSolver))
    gac = _run_records(solver, mesh, shapes, both, mach, dt_star, progress)
    solver_seconds = time.perf_counter() - t_solver
    if progress is not None:
        progress(0.92, "identifying ARX model")
    n = int(n_steps)
    orders = [(na, nb), *[(int(a), int(b)) for a, b in order_fallbacks]]
    fit = _fit_orders(orders, nrmse_tol, lambda a, b: identify(
        exc.train, gac, both, n, m, a, b, ridge, dt_star, k_max, reduce_order, hsv_tol, reduce_tol, progress,
        validation_band))
    arx, full, ss, hsv, pred, val = fit.arx, fit.full, fit.ss, fit.hsv, fit.pred, fit.val
    na, nb, notes = fit.na, fit.nb, fit.notes
    distortion = None if validation_band is None else out_of_band_share(gac[n:], dt_star, validation_band)
    if distortion is not None and validation_band is not None and float(distortion.max()) > DISTORTION_WARN:
        notes.append(f"{100 * float(distortion.max()):.1f} % of the validation GAC's RMS lies above k = "
                     f"{validation_band:g}, outside the excitation band (k <= {k_max:g}): response no linear model of "
                     "the input gives (a nonlinear or numerical response); the validation NRMSE counts k <= "
                     f"{validation_band:g}")
    if progress is not None:
        progress(1.0, f"trained: max validation NRMSE {val.max():.4f}")
    info = solver.info(mach) if hasattr(solver, "info") else None
    return TrainedRom(
        solver=str(getattr(solver, "name", type(solver).__name__)),
        mach=mach,
        dt_star=dt_star,
        c_ref=float(mesh.c_ref),
        n_basis=m,
        na=int(na),
        nb=int(nb),
        k_max=float(k_max),
        seed=int(seed),
        ridge=float(ridge),
        arx=arx,
        ss=ss,
        n_states_full=full.n_states,
        hsv=hsv,
        signals_train=exc.train,
        signals_validation=exc.validation,
        gac_train=gac[:n],
        gac_validation=gac[n:],
        predicted_validation=pred,
        training_nrmse=fit.training_nrmse,
        validation_nrmse=val,
        arx_validation_nrmse=fit.arx_val,
        spectral_radius=float(ss.spectral_radius()),
        nrmse_tol=float(nrmse_tol),
        warnings=(list(info.warnings) if info is not None else []) + notes,
        validation_band=None if validation_band is None else float(validation_band),
        validation_distortion=distortion,
        train_seconds=time.perf_counter() - t_start,
        solver_seconds=solver_seconds,
        ar_ridge=float(fit.ar_ridge),
    )


def _run_records(solver: UnsteadySolver, mesh: StandardMesh, shapes: np.ndarray, both: Records, mach: float,
                 dt_star: float, progress: ProgressFn | None) -> np.ndarray:
    """The solver's GAC [T_train + T_val, m] on both records (one continued run, or two from rest side by side by a
    ``RecordsSolver``); TrainingError when its shape is wrong or a value is not finite."""

    def solver_progress(frac: float, msg: str) -> None:
        if progress is not None:
            progress(0.9 * frac, msg)

    if isinstance(solver, RecordsSolver):
        out = np.vstack(solver.simulate_records(mesh, shapes, [both.train, both.validation], mach, dt_star,
                                                progress=solver_progress))
    else:
        out = solver.simulate(mesh, shapes, both.signals, mach, dt_star, progress=solver_progress)
    gac = np.asarray(out, dtype=float)
    if gac.shape != both.signals.shape or not np.all(np.isfinite(gac)):
        raise TrainingError(f"solver {solver.name!r} returned GAC of shape {gac.shape} (expected {both.signals.shape}) "
                            "or non-finite values")
    return gac


def _fit_orders(orders: list[tuple[int, int]], nrmse_tol: float, fit_one: Callable[[int, int], Fit]) -> Fit:
    """The first fit of ``orders`` (na, nb) in turn whose validation NRMSE meets nrmse_tol (with a note when it is
    not the first); TrainingError naming the outputs of the best one when none does."""
    fits: list[Fit] = []
    for na, nb in orders:  # a few candidate orders
        fits.append(fit_one(na, nb))
        if np.all(fits[-1].val <= nrmse_tol):
            break
    fit = min(fits, key=lambda f: float(np.max(f.val)))
    bad = [int(i) for i in np.flatnonzero(~(fit.val <= nrmse_tol))]
    if bad:
        detail = ", ".join(f"output {i}: {fit.val[i]:.4f}" for i in bad)
        raise TrainingError(f"validation NRMSE above nrmse_tol = {nrmse_tol:g} for {detail} "
                            f"(states {fit.ss.n_states}, na = {fit.na}, nb = {fit.nb}"
                            f"{'; best of orders ' + str([(f.na, f.nb) for f in fits]) if len(fits) > 1 else ''})",
                            outputs=bad)
    if len(fits) > 1:
        failed = ", ".join(f"{f.na}/{f.nb} ({100 * float(np.max(f.val)):.2f} %)" for f in fits if f is not fit)
        fit.notes.append(f"ARX orders {failed} missed the validation tolerance; refitted with {fit.na}/{fit.nb} on "
                         "the same records")
    return fit


def with_symmetry(solver: UnsteadySolver, symmetry: str | None) -> UnsteadySolver:
    """``solver`` with its root ``symmetry`` replaced (None: unchanged); InputError naming ``symmetry`` without one."""
    if symmetry is None:
        return solver
    image_sign(symmetry)  # InputError naming symmetry for an unknown one
    if not (dataclasses.is_dataclass(solver) and hasattr(solver, "symmetry")):
        raise InputError("symmetry", f"solver {getattr(solver, 'name', type(solver).__name__)!r} has no setting "
                                     "'symmetry'; pass a solver built for the root condition instead")
    return dataclasses.replace(solver, symmetry=symmetry)


def with_minimal_realization(rom: Any) -> Any:
    """A TrainedRom with :func:`minimal_arx_realization` of its model when it still holds the full ARX realization
    (ROMs stored before 2026-12-04, whose singular eigenvectors made the flutter search lose or mislabel crossings,
    docs/transonic.md 7.9); ``rom`` itself otherwise (another kind of ROM; reduced, stabilized, anchored or already
    minimal)."""
    if (not isinstance(rom, TrainedRom) or rom.anchor_k is not None or rom.ss.n_states != rom.n_states_full
            or rom.ss.n_states == 0):
        return rom
    full = arx_to_ss(rom.arx, rom.dt_star)
    if full.A.shape != rom.ss.A.shape or not np.array_equal(full.A, rom.ss.A):  # not the plain ARX realization
        return rom
    rec = Records(rom.signals_train, rom.signals_validation, continued=rom.solver != "tsd")
    ss = minimal_arx_realization(rom.ss, rec, np.vstack([rom.gac_train, rom.gac_validation]), len(rom.signals_train))
    return rom if ss is rom.ss else dataclasses.replace(rom, ss=ss, spectral_radius=float(ss.spectral_radius()))
