"""MIMO ARX identification: f(t) = sum_{i=1..na} A_i f(t-i) + sum_{i=0..nb-1} B_i u(t-i).

Discrete time index t on the nondimensional grid t* = t * dt_star; inputs u [T, m_in] (generalized
displacements), outputs f [T, m_out] (GAC, m^3). Data are assumed to start from rest (zero before t = 0).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from romams_core.errors import InputError
from romams_core.validation import check_int

__all__ = ["ArxModel", "fit_arx", "arx_simulate", "nrmse", "band_nrmse", "band_part", "out_of_band_share", "regressors"]


@dataclass
class ArxModel:
    """ARX coefficients: a [na, m_out, m_out] (A_1..A_na), b [nb, m_out, m_in] (B_0..B_nb-1), step dt_star."""

    a: np.ndarray
    b: np.ndarray
    dt_star: float = float("nan")

    @property
    def na(self) -> int:
        """Output delay order."""
        return int(self.a.shape[0])

    @property
    def nb(self) -> int:
        """Input delay order (taps 0..nb-1)."""
        return int(self.b.shape[0])


def regressors(u: np.ndarray, f: np.ndarray, na: int, nb: int) -> np.ndarray:
    """Regression matrix [T, na*m_out + nb*m_in]: rows [f(t-1) .. f(t-na), u(t) .. u(t-nb+1)], zero before t = 0."""
    n_t = u.shape[0]
    lag = max(na, nb)
    fp = np.vstack([np.zeros((lag, f.shape[1])), f])
    up = np.vstack([np.zeros((lag, u.shape[1])), u])
    cols = [fp[lag - i : lag - i + n_t] for i in range(1, na + 1)]  # loop over a handful of lags
    cols += [up[lag - i : lag - i + n_t] for i in range(nb)]
    return np.hstack(cols)


def fit_arx(
    u: np.ndarray,
    f: np.ndarray,
    na: int = 8,
    nb: int = 8,
    ridge: float = 0.0,
    dt_star: float = float("nan"),
    ar_ridge: float = 0.0,
) -> ArxModel:
    """Least-squares ARX fit of outputs f [T, m_out] to inputs u [T, m_in]; all outputs in ONE solve.

    Columns of the regression matrix are scaled to unit RMS before solving; ``ridge`` (>= 0, dimensionless)
    adds ridge * T * I to the normal equations of the scaled problem (Tikhonov regularization), and
    ``ar_ridge`` adds ar_ridge * T on the autoregressive (A_i) coefficients only: a tiny value (1e-10) removes
    the spurious, nearly unstable poles that oversampled band-limited data leave in an unconstrained fit.
    """
    check_int("na", na, 0, 64)
    check_int("nb", nb, 1, 64)
    u = np.asarray(u, dtype=float)
    f = np.asarray(f, dtype=float)
    if u.ndim != 2 or f.ndim != 2 or u.shape[0] != f.shape[0]:
        raise InputError("u", f"u [T, m_in] and f [T, m_out] need equal T, got {u.shape} and {f.shape}")
    if not (np.all(np.isfinite(u)) and np.all(np.isfinite(f))):
        raise InputError("u", "u and f must be finite")
    if not (math.isfinite(ridge) and ridge >= 0):
        raise InputError("ridge", f"must be a finite number >= 0, got {ridge!r}")
    if not (math.isfinite(ar_ridge) and ar_ridge >= 0):
        raise InputError("ar_ridge", f"must be a finite number >= 0, got {ar_ridge!r}")
    m_out, m_in = f.shape[1], u.shape[1]
    n_par = na * m_out + nb * m_in
    if u.shape[0] < 2 * n_par:
        raise InputError("u", f"{u.shape[0]} samples are too few for {n_par} parameters per output "
                              f"(need >= {2 * n_par})")
    phi = regressors(u, f, na, nb)
    scale = np.sqrt(np.mean(phi**2, axis=0))
    scale[scale == 0] = 1.0
    phi_s = phi / scale
    if ridge > 0 or ar_ridge > 0:
        weight = np.full(n_par, ridge)
        weight[: na * m_out] += ar_ridge
        phi_s = np.vstack([phi_s, np.diag(np.sqrt(weight * phi.shape[0]))])
        rhs = np.vstack([f, np.zeros((n_par, m_out))])
    else:
        rhs = f
    theta = np.linalg.lstsq(phi_s, rhs, rcond=None)[0] / scale[:, None]  # [n_par, m_out]
    a = theta[: na * m_out].reshape(na, m_out, m_out).transpose(0, 2, 1)
    b = theta[na * m_out :].reshape(nb, m_in, m_out).transpose(0, 2, 1)
    return ArxModel(a=np.ascontiguousarray(a), b=np.ascontiguousarray(b), dt_star=float(dt_star))


def arx_simulate(model: ArxModel, u: np.ndarray) -> np.ndarray:
    """Free-run (simulation-mode) output [T, m_out] of an ARX model driven by u [T, m_in] from rest."""
    u = np.asarray(u, dtype=float)
    na, nb = model.na, model.nb
    m_out = model.a.shape[1] if na else model.b.shape[1]
    n_t = u.shape[0]
    lag = max(na, nb)
    up = np.vstack([np.zeros((lag, u.shape[1])), u])
    # exogenous part for all steps at once, then the (sequential) autoregression
    exo = sum(up[lag - i : lag - i + n_t] @ model.b[i].T for i in range(nb))
    f = np.zeros((n_t + lag, m_out))
    a_stack = np.hstack([model.a[i] for i in range(na)]) if na else np.zeros((m_out, 0))
    for t in range(n_t):
        past = f[t + lag - na : t + lag][::-1].ravel() if na else np.zeros(0)
        f[t + lag] = exo[t] + a_stack @ past
    return f[lag:]


def nrmse(reference: np.ndarray, predicted: np.ndarray) -> np.ndarray:
    """Normalized RMS error per output [m]: RMS(predicted - reference) / RMS(reference) (dimensionless)."""
    ref = np.asarray(reference, dtype=float)
    err = np.sqrt(np.mean((np.asarray(predicted, dtype=float) - ref) ** 2, axis=0))
    rms = np.sqrt(np.mean(ref**2, axis=0))
    return np.where(rms > 0, err / np.where(rms > 0, rms, 1.0), np.where(err > 0, np.inf, 0.0))


def band_part(x: np.ndarray, dt_star: float, k_band: float) -> np.ndarray:
    """The part of records x [T, m] at reduced frequencies k <= k_band (omega t* = 2 k; the record's DFT with the
    bins above it zeroed: an orthogonal projection, so the band's and the rest's energies add up to the whole)."""
    x = np.asarray(x, dtype=float)
    spec = np.fft.rfft(x, axis=0)
    spec[2.0 * np.pi * np.fft.rfftfreq(x.shape[0], d=dt_star) > 2.0 * k_band] = 0.0
    return np.fft.irfft(spec, n=x.shape[0], axis=0)


def band_nrmse(reference: np.ndarray, predicted: np.ndarray, dt_star: float, k_band: float) -> np.ndarray:
    """``nrmse`` of the records' parts at k <= k_band (``band_part``) per output [m]: a linear model's error where
    the input excites it, without what a nonlinear or numerical response puts far outside the input's band."""
    ref = np.asarray(reference, dtype=float)
    return nrmse(band_part(ref, dt_star, k_band), band_part(predicted, dt_star, k_band))


def out_of_band_share(reference: np.ndarray, dt_star: float, k_band: float) -> np.ndarray:
    """RMS share [m] of records [T, m] at k > k_band (the rest of ``band_part``): for a multisine input band-limited
    below k_band it is response that no linear model of the input can give (distortion, numerical noise)."""
    ref = np.asarray(reference, dtype=float)
    rms = np.sqrt(np.mean(ref**2, axis=0))
    rest = np.sqrt(np.mean((ref - band_part(ref, dt_star, k_band)) ** 2, axis=0))
    return np.where(rms > 0, rest / np.where(rms > 0, rms, 1.0), 0.0)
