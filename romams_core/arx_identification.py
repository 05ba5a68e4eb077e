"""ARX identification of one training run: fit, stabilization, reduction and the minimal realization, each judged
on the run's validation record (``train_rom`` in ``romams_core.training`` drives them)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from romams_core.aero.protocol import ProgressFn
from romams_core.arx import ArxModel, arx_simulate, band_nrmse, fit_arx, nrmse
from romams_core.realization import minimal_realization, real_modal_form
from romams_core.statespace import (
    DiscreteSS,
    arx_to_ss,
    balanced_models,
    balanced_truncation,
    refit_output_map,
    reflect_unstable_poles,
)

#: Largest RMS difference between the minimal and the full realization's validation outputs, as a fraction of the
#: largest output RMS of the records (:func:`minimal_arx_realization`; measured 1e-6 on TSD ROMs).
MINIMAL_MATCH_TOL = 1e-4
#: Condition number of the modal transformation above which the minimal realization stays in staircase coordinates.
MODAL_COND_MAX = 1e10
#: AR-only Tikhonov levels tried, in order, when the plain least-squares ARX fit is unstable.
AR_RIDGES = (1e-12, 1e-11, 1e-10, 1e-9, 1e-8, 1e-7, 1e-6)


class TrainingError(RuntimeError):
    """Identification failed (tolerance not met or unstable model); ``outputs`` lists the offending outputs."""

    def __init__(self, message: str, outputs: list[int] | None = None) -> None:
        super().__init__(message)
        self.outputs = list(outputs or [])


def record_error(reference: np.ndarray, predicted: np.ndarray, dt_star: float, band: float | None) -> np.ndarray:
    """NRMSE [m] of predicted against reference records [T, m]: of the whole records, or of their parts at
    k <= ``band`` (``arx.band_nrmse``)."""
    return nrmse(reference, predicted) if band is None else band_nrmse(reference, predicted, dt_star, band)


@dataclass
class Records:
    """The training and validation signals, [T_train, m] and [T_val, m], as one run (continued) or two from rest."""

    train: np.ndarray
    validation: np.ndarray
    continued: bool = True

    @property
    def signals(self) -> np.ndarray:
        """[T_train + T_val, m] both signals, stacked."""
        return np.vstack([self.train, self.validation])

    def simulate(self, model: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
        """[T_train + T_val, m] output of ``model`` (signals -> outputs, from rest) on the records as they ran."""
        if self.continued:
            return model(self.signals)
        return np.vstack([model(self.train), model(self.validation)])


@dataclass
class Fit:
    """One identified model of a training run: ARX, its realization, the (reduced) ROM and its validation."""

    na: int
    nb: int
    arx: ArxModel
    full: DiscreteSS
    ss: DiscreteSS
    hsv: np.ndarray
    pred: np.ndarray  # [T_val, m] ROM output on the validation signal
    val: np.ndarray  # [m] validation NRMSE of ss
    training_nrmse: np.ndarray
    arx_val: np.ndarray
    ar_ridge: float
    notes: list[str]


def identify(
    u_train: np.ndarray, gac: np.ndarray, both: Records, n: int, m: int, na: int, nb: int, ridge: float,
    dt_star: float, k_max: float, reduce_order: int | str | None, hsv_tol: float | None, reduce_tol: float,
    progress: ProgressFn | None, band: float | None = None,
) -> Fit:
    """ARX of orders (na, nb) fitted on the first n samples of gac [T, m], stabilized, reduced and validated (every
    NRMSE counted at k <= ``band``, None: the whole record, ``record_error``)."""

    def score(ref: np.ndarray, pred: np.ndarray) -> np.ndarray:
        return record_error(ref, pred, dt_star, band)

    arx = fit_arx(u_train, gac[:n], na=na, nb=nb, ridge=ridge, dt_star=dt_star)
    full = arx_to_ss(arx, dt_star)
    notes: list[str] = []
    rho = full.spectral_radius()
    ar_ridge = 0.0
    for lam in AR_RIDGES if not rho < 1.0 else ():  # a few regularization levels
        trial = fit_arx(u_train, gac[:n], na=na, nb=nb, ridge=ridge, dt_star=dt_star, ar_ridge=lam)
        trial_ss = arx_to_ss(trial, dt_star)
        if trial_ss.spectral_radius() < 1.0:
            notes.append(f"plain ARX fit was unstable (spectral radius {rho:.4f}); refitted with ar_ridge = {lam:g}")
            arx, full, ar_ridge = trial, trial_ss, lam
            break
    pred_arx = both.simulate(lambda u: arx_simulate(arx, u)) if full.spectral_radius() < 1.0 else np.zeros_like(gac)
    if not full.spectral_radius() < 1.0:
        full, pred_arx, n_ref = stabilize(full, u_train, gac, both, n, score)
        notes.append(
            f"ARX fit had {n_ref} unstable pole(s) (spectral radius {rho:.4f}) even with ar_ridge; reflected to "
            "1/conj(z) (output map refitted when that validated better), then validated"
        )
    ss, hsv = full, np.zeros(0)
    arx_val = score(gac[n:], pred_arx[n:])  # the full realization's validation error
    if reduce_order == "auto":
        if progress is not None:
            progress(0.95, "frequency-limited balanced truncation")
        ss, hsv = auto_reduce(full, both, gac, n, m, k_max, reduce_tol, score)
    elif reduce_order is not None or hsv_tol is not None:
        if progress is not None:
            progress(0.95, "balanced truncation")
        ss, hsv = balanced_truncation(full, order=None if isinstance(reduce_order, str) else reduce_order,
                                      hsv_tol=hsv_tol)
    pred = both.simulate(ss.simulate)[n:] if ss is not full else pred_arx[n:]
    return Fit(na=na, nb=nb, arx=arx, full=full, ss=ss, hsv=hsv, pred=pred, val=score(gac[n:], pred),
                training_nrmse=score(gac[:n], pred_arx[:n]), arx_val=arx_val,
                ar_ridge=ar_ridge, notes=notes)


def stabilize(
    full: DiscreteSS, u_train: np.ndarray, gac: np.ndarray, both: Records, n_train: int,
    score: Callable[[np.ndarray, np.ndarray], np.ndarray] = nrmse,
) -> tuple[DiscreteSS, np.ndarray, int]:
    """Reflect unstable poles; keep the better (validation NRMSE) of plain reflection and reflection + C, D refit."""
    refl, n_ref = reflect_unstable_poles(full)
    if not refl.spectral_radius() < 1.0:
        raise TrainingError(
            f"identified ARX model is unstable (spectral radius {full.spectral_radius():.6f} >= 1) and could not be "
            "stabilized; try other na/nb or another signal length"
        )
    best: tuple[float, DiscreteSS, np.ndarray] | None = None
    for cand in (refl, refit_output_map(refl, u_train, gac[:n_train])):  # two candidates
        pred = both.simulate(cand.simulate)
        err = float(np.max(score(gac[n_train:], pred[n_train:])))
        if best is None or err < best[0]:
            best = (err, cand, pred)
    assert best is not None
    return best[1], best[2], n_ref


def auto_reduce(
    full: DiscreteSS, u: Records, f: np.ndarray, n_train: int, m: int, k_band: float, tol: float,
    score: Callable[[np.ndarray, np.ndarray], np.ndarray] = nrmse,
) -> tuple[DiscreteSS, np.ndarray]:
    """Smallest stable band-limited balanced truncation (orders m, 2m, ...) with validation NRMSE <= tol; when
    none passes, the minimal realization of ``full`` (:func:`minimal_arx_realization`)."""
    orders = list(range(m, full.n_states, m))
    models, hsv = balanced_models(full, orders, k_band=k_band)
    for red in models:  # a handful of candidate orders
        if not red.is_stable():
            continue
        err = score(f[n_train:], u.simulate(red.simulate)[n_train:])
        if np.all(err <= tol):
            return red, hsv
    return minimal_arx_realization(full, u, f, n_train), hsv


def minimal_arx_realization(full: DiscreteSS, u: Records, f: np.ndarray, n_train: int) -> DiscreteSS:
    """``full`` without its surplus states: the minimal realization (orthogonal staircase, exact), in real modal
    form when that transformation is well conditioned (condition < ``MODAL_COND_MAX``). Kept only if it is stable
    and its validation output differs from ``full``'s by at most ``MINIMAL_MATCH_TOL`` of the largest output RMS
    of ``f`` [T, m]; else the minimal realization as it is, under the same test; else ``full``.

    An ARX realization carries the delayed inputs as states: repeated, defective poles at z = 0 whose
    eigenvectors are numerically singular (condition 1e34 to 1e148 measured on TSD ROMs), so the flutter search
    could not diagonalize it and fell back to full eigenvectors at every step. The match is judged on the models'
    outputs, not on their errors against the records, so the records' noise does not decide. docs/transonic.md
    7.9."""
    minimal = minimal_realization(full)
    if minimal.n_states >= full.n_states:
        return full
    modal, cond = real_modal_form(minimal)
    val = slice(n_train, None)
    ref = u.simulate(full.simulate)[val]
    bound = MINIMAL_MATCH_TOL * float(np.max(np.sqrt(np.mean(f[val] ** 2, axis=0))))
    for cand in (modal, minimal) if cond < MODAL_COND_MAX else (minimal,):  # two candidates at most
        if cand.is_stable() and float(np.max(np.sqrt(np.mean((u.simulate(cand.simulate)[val] - ref) ** 2,
                                                                  axis=0)))) <= bound:
            return cand
    return full
