"""Rational function approximation (RFA) of tabulated generalized aerodynamic forces, Roger's form.

In the nondimensional Laplace variable p = s c_ref / V (t* = t V / c_ref; harmonic motion p = 2 i k with
k = omega b / V on b = c_ref / 2):

    Q(p) = A0 + A1 p + A2 p^2 + sum_j A_(j) p / (p + beta_j),   beta_j > 0 (lag roots),

each A an [m, m] real matrix. A0 is the steady value Q(0) when the table holds k = 0 (then it is kept exactly,
so static aeroelastic results are not changed by the fit); A1, A2 and the lag matrices come from one linear
least-squares problem with the same regressors for every entry. The lag roots are chosen automatically:
for n = 1 .. ``max_lags`` lags they are optimized (in log space, variable projection: the linear part is
solved for each trial set) and the smallest n whose worst entry error is below ``tol`` is kept.

Error measure ("physically weighted"): entry (i, j) is compared with sqrt(max_k |Q_ii| max_k |Q_jj|), the
scale of the two diagonal terms it couples, so it does not depend on the scaling of the shapes and a small
cross-coupling term is not fitted at the expense of the terms that matter for flutter. The reported
``fit_error`` [m, m] is the worst such error over the table for each entry.

Realization (continuous, in t*): p / (p + beta) = 1 - beta / (p + beta), so with m states per lag
(dx_j/dt* = -beta_j x_j + u) Q = D + C (p I - A)^-1 B + D1 p + D2 p^2 with D = A0 + sum_j A_(j),
C = [-beta_j A_(j)], D1 = A1, D2 = A2. ``romams_core.flutter`` couples this model as it is.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from romams_core.errors import InputError
from romams_core.statespace import ContinuousSS

__all__ = ["RogerRfa", "RfaFit", "fit_rfa", "entry_scale", "fit_errors"]

DEFAULT_TOL = 0.005  # worst weighted entry error accepted by the automatic lag choice
DEFAULT_MAX_LAGS = 6


@dataclass
class RogerRfa:
    """Roger RFA Q(p) = A0 + A1 p + A2 p^2 + sum_j A_lag[j] p / (p + lags[j]) in p = s c_ref / V (m^3 per unit)."""

    lags: np.ndarray  # [nl] beta_j > 0 (t* units)
    a0: np.ndarray  # [m, m]
    a1: np.ndarray  # [m, m]
    a2: np.ndarray  # [m, m]
    a_lag: np.ndarray  # [nl, m, m]

    @property
    def n_lags(self) -> int:
        """Number of lag roots."""
        return int(np.asarray(self.lags).size)

    def __call__(self, k: np.ndarray) -> np.ndarray:
        """Q at reduced frequencies k [n] (on the semichord): [n, m, m] complex."""
        p = 2j * np.atleast_1d(np.asarray(k, dtype=float))
        basis = _regressors(p, np.asarray(self.lags, float))  # [n, 2 + nl]
        mats = np.concatenate([self.a1[None], self.a2[None], self.a_lag])  # [2 + nl, m, m]
        return self.a0[None] + np.einsum("nr,rij->nij", basis, mats)

    def state_space(self) -> ContinuousSS:
        """Continuous realization in t* with m states per lag root (module docstring)."""
        m = self.a0.shape[0]
        lags = np.asarray(self.lags, float)
        nl = lags.size
        a = np.kron(np.diag(-lags), np.eye(m)) if nl else np.zeros((0, 0))
        b = np.tile(np.eye(m), (nl, 1)) if nl else np.zeros((0, m))
        c = np.hstack([-beta * self.a_lag[j] for j, beta in enumerate(lags)]) if nl else np.zeros((m, 0))
        d = self.a0 + self.a_lag.sum(axis=0)
        return ContinuousSS(A=a, B=b, C=c, D=d, D1=self.a1.copy(), D2=self.a2.copy())


@dataclass
class RfaFit:
    """Result of :func:`fit_rfa`: the RFA, its weighted entry errors and the lag search it came from."""

    rfa: RogerRfa
    fit_error: np.ndarray  # [m, m] worst weighted error over the table, per entry
    max_error: float
    tol: float
    errors_by_lags: dict[int, float]  # worst entry error reached with n lags


def _regressors(p: np.ndarray, lags: np.ndarray) -> np.ndarray:
    """Complex regressors [n, 2 + nl] of A1, A2 and the lag matrices at p [n]."""
    return np.column_stack([p, p * p, *(p / (p + b) for b in lags)]) if lags.size else np.column_stack([p, p * p])


def entry_scale(h: np.ndarray) -> np.ndarray:
    """Weight scale [m, m] of each entry: sqrt(max_k |H_ii| max_k |H_jj|) (floored at 1e-12 of the largest)."""
    diag = np.max(np.abs(np.diagonal(h, axis1=1, axis2=2)), axis=0)
    diag = np.maximum(diag, 1e-12 * max(float(np.max(np.abs(h))), 1e-300))
    return np.sqrt(np.outer(diag, diag))


def fit_errors(h_fit: np.ndarray, h: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """Worst weighted error over the table per entry, [m, m]."""
    return np.max(np.abs(h_fit - h), axis=0) / scale


def _solve(k: np.ndarray, h: np.ndarray, lags: np.ndarray, a0: np.ndarray | None) -> RogerRfa:
    """Linear least squares of A1, A2, A_lag (and A0 unless given) for fixed lags."""
    m = h.shape[1]
    p = 2j * k
    reg = _regressors(p, lags)
    rhs = h.reshape(k.size, m * m)
    if a0 is None:
        reg = np.column_stack([np.ones(k.size), reg])
    else:
        rhs = rhs - a0.reshape(1, -1)
    mat = np.concatenate([reg.real, reg.imag])
    y = np.concatenate([rhs.real, rhs.imag])
    col = np.linalg.norm(mat, axis=0)
    col[col == 0] = 1.0
    sol = np.linalg.lstsq(mat / col, y, rcond=None)[0] / col[:, None]
    if a0 is None:
        a0, sol = sol[0].reshape(m, m), sol[1:]
    mats = sol.reshape(-1, m, m)
    return RogerRfa(lags=lags.copy(), a0=np.array(a0), a1=mats[0], a2=mats[1], a_lag=mats[2:])


def _objective(log_lags: np.ndarray, k: np.ndarray, h: np.ndarray, a0: np.ndarray | None, scale: np.ndarray) -> float:
    """Sum of squared weighted residuals for lags exp(log_lags) (variable projection)."""
    lags = np.exp(log_lags)
    rfa = _solve(k, h, lags, a0)
    return float(np.sum(np.abs((rfa(k) - h) / scale) ** 2))


def _initial_lags(n: int, k_max: float) -> np.ndarray:
    """Start lags [n] spread geometrically over 0.1 .. 1.2 of the table's p range (2 k_max)."""
    top = 2.0 * k_max
    return top * np.geomspace(0.1, 1.2, n) if n > 1 else np.array([0.4 * top])


def fit_rfa(
    k: np.ndarray,
    h: np.ndarray,
    *,
    n_lags: int | None = None,
    max_lags: int = DEFAULT_MAX_LAGS,
    tol: float = DEFAULT_TOL,
) -> RfaFit:
    """Fit a Roger RFA to the table H [nk, m, m] at reduced frequencies k [nk] (ascending, on the semichord).

    ``n_lags`` fixes the number of lag roots; None chooses the smallest n <= ``max_lags`` whose worst weighted
    entry error is below ``tol`` (else the best). Lags are bounded to [0.01, 10] x 2 k_max. InputError names
    the field for a bad table.
    """
    k = np.asarray(k, dtype=float)
    h = np.asarray(h, dtype=complex)
    if k.ndim != 1 or k.size < 3 or not np.all(np.isfinite(k)) or k[0] < 0 or np.any(np.diff(k) <= 0):
        raise InputError("k_values", "need at least 3 finite, ascending reduced frequencies >= 0")
    if h.ndim != 3 or h.shape[0] != k.size or h.shape[1] != h.shape[2] or not np.all(np.isfinite(h)):
        raise InputError("gaf", f"must be finite with shape ({k.size}, m, m), got {h.shape}")
    if n_lags is not None and not (isinstance(n_lags, int) and 0 <= n_lags <= 12):
        raise InputError("n_lags", f"must be an integer in 0..12, got {n_lags!r}")
    if not (isinstance(max_lags, int) and 0 <= max_lags <= 12):
        raise InputError("max_lags", f"must be an integer in 0..12, got {max_lags!r}")
    if not (math.isfinite(tol) and tol > 0):
        raise InputError("tol", f"must be a finite number > 0, got {tol!r}")
    a0 = h[0].real.copy() if k[0] == 0.0 else None
    n_free = 2 + (0 if a0 is not None else 1)
    n_data = 2 * (k.size - (1 if a0 is not None else 0))
    k_max = float(k[-1])
    scale = entry_scale(h)
    bounds = (math.log(0.01 * 2 * k_max), math.log(10.0 * 2 * k_max))
    counts = [n_lags] if n_lags is not None else list(range(0, max_lags + 1))
    best: tuple[float, RogerRfa] | None = None
    errors: dict[int, float] = {}
    for n in counts:
        if n_free + n > n_data:
            break
        lags = _initial_lags(n, k_max) if n else np.zeros(0)
        if n:
            res = minimize(_objective, np.log(lags), args=(k, h, a0, scale), method="L-BFGS-B",
                           bounds=[bounds] * n, options={"maxiter": 200})
            lags = np.sort(np.exp(res.x))
        rfa = _solve(k, h, lags, a0)
        err = float(np.max(fit_errors(rfa(k), h, scale)))
        errors[n] = err
        if best is None or err < best[0]:
            best = (err, rfa)
        if n_lags is None and err <= tol:
            break
    if best is None:
        raise InputError("k_values", f"{k.size} reduced frequencies are too few to fit the RFA")
    rfa = best[1]
    fe = fit_errors(rfa(k), h, scale)
    return RfaFit(rfa=rfa, fit_error=fe, max_error=float(np.max(fe)), tol=float(tol), errors_by_lags=errors)
