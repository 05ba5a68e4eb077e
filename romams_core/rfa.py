"""Rational function approximation (RFA) of tabulated generalized aerodynamic forces, Roger's form.

In the nondimensional Laplace variable p = s c_ref / V (t* = t V / c_ref; harmonic motion p = 2 i k with
k = omega b / V on b = c_ref / 2):

    Q(p) = A0 + A1 p + A2 p^2 + sum_j A_(j) p / (p + beta_j)
           + sum_l [B_l (g_l(p) + conj g_l) + C_l i (g_l(p) - conj g_l)],  g_l(p) = p / (p + gamma_l),

each A, B, C an [m, m] real matrix; beta_j > 0 are real lag roots and gamma_l (Re > 0, Im > 0) complex lag
roots taken with their conjugates ("conj g_l" is p / (p + conj gamma_l)), so every term is real in the time
domain. The complex pairs are an extension of Roger's real lags: at high subsonic Mach the compressible
kernel makes the GAF wavy in k, which real lags follow only by crowding together (ill-conditioned fits).

A0 is the steady value Q(0) when the table holds k = 0 (then it is kept exactly,
so static aeroelastic results are not changed by the fit); A1, A2 and the lag matrices come from one linear
least-squares problem with the same regressors for every entry. The lag roots are chosen automatically:
for n = 1 .. ``max_lags`` lags they are optimized (in log space, variable projection: the linear part is
solved for each trial set); configurations are tried by increasing state count (a real lag costs m states, a
complex pair 2 m) and the first whose worst entry error is below ``tol`` is kept (else the best).

Error measure ("physically weighted"): entry (i, j) is compared with sqrt(max_k |Q_ii| max_k |Q_jj|), the
scale of the two diagonal terms it couples, so it does not depend on the scaling of the shapes and a small
cross-coupling term is not fitted at the expense of the terms that matter for flutter. The reported
``fit_error`` [m, m] is the worst such error over the table for each entry.

Realization (continuous, in t*): p / (p + beta) = 1 - beta / (p + beta), so with m states per real lag
(dx_j/dt* = -beta_j x_j + u) Q = D + C (p I - A)^-1 B + D1 p + D2 p^2 with D = A0 + sum_j A_(j) + 2 sum_l B_l,
C = [-beta_j A_(j)], D1 = A1, D2 = A2. A complex pair uses the real and imaginary parts of one complex state
x = u / (p + gamma) (2 m states): dx_r/dt* = -g_r x_r + g_i x_i + u, dx_i/dt* = -g_i x_r - g_r x_i, output
(-2 g_r B + 2 g_i C) x_r + (2 g_i B + 2 g_r C) x_i. ``romams_core.flutter`` couples this model as it is.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import minimize

from romams_core.errors import InputError
from romams_core.statespace import ContinuousSS

__all__ = ["RogerRfa", "RfaFit", "fit_rfa", "check_lag_settings", "entry_scale", "fit_errors", "configurations"]

DEFAULT_TOL = 0.005  # worst weighted entry error accepted by the automatic lag choice
DEFAULT_MAX_LAGS = 8  # most lag-state units (a real lag is 1, a complex pair 2) the automatic choice tries
#: Lag-root magnitudes as fractions of the table's top |p| = 2 k_max. A lag far above the table acts inside it
#: like a polynomial correction to A1 and A2, and then takes over beyond it: the aerodynamic damping at high k
#: (a constant-density sweep from V -> 0) loses its sign (seen on the Goland wing at M 0 with a lag at 20 k_max).
LAG_RANGE = (0.01, 1.5)


@dataclass
class RogerRfa:
    """Roger RFA in p = s c_ref / V (m^3 per unit): real lags and complex lag pairs (module docstring)."""

    lags: np.ndarray  # [nl] real lag roots beta_j > 0 (t* units)
    a0: np.ndarray  # [m, m]
    a1: np.ndarray  # [m, m]
    a2: np.ndarray  # [m, m]
    a_lag: np.ndarray  # [nl, m, m]
    pairs: np.ndarray = field(default_factory=lambda: np.zeros(0, complex))  # [np] gamma_l, Re > 0, Im > 0
    a_pair: np.ndarray = field(default_factory=lambda: np.zeros((0, 2, 0, 0)))  # [np, 2, m, m]: B_l, C_l

    @property
    def n_lags(self) -> int:
        """Number of lag roots (a complex pair counts two)."""
        return int(np.asarray(self.lags).size + 2 * np.asarray(self.pairs).size)

    def __call__(self, k: np.ndarray) -> np.ndarray:
        """Q at reduced frequencies k [n] (on the semichord): [n, m, m] complex."""
        p = 2j * np.atleast_1d(np.asarray(k, dtype=float))
        basis = _regressors(p, np.asarray(self.lags, float), np.asarray(self.pairs, complex))
        m = self.a0.shape[0]
        mats = np.concatenate([self.a1[None], self.a2[None], self.a_lag.reshape(-1, m, m),
                               self.a_pair.reshape(-1, m, m)])
        return self.a0[None] + np.einsum("nr,rij->nij", basis, mats)

    def state_space(self) -> ContinuousSS:
        """Continuous realization in t*: m states per real lag, 2 m per complex pair (module docstring)."""
        m = self.a0.shape[0]
        eye = np.eye(m)
        blocks_a, blocks_c = [], []
        for j, beta in enumerate(np.asarray(self.lags, float)):
            blocks_a.append(-beta * eye)
            blocks_c.append(-beta * self.a_lag[j])
        d = self.a0 + self.a_lag.sum(axis=0)
        if np.asarray(self.pairs).size:
            d = d + 2.0 * self.a_pair[:, 0].sum(axis=0)
        b_rows = [eye] * len(blocks_a)
        for l_, g in enumerate(np.asarray(self.pairs, complex)):
            bb, cc = self.a_pair[l_]
            blocks_a.append(np.block([[-g.real * eye, g.imag * eye], [-g.imag * eye, -g.real * eye]]))
            blocks_c.append(np.hstack([-2 * g.real * bb + 2 * g.imag * cc, 2 * g.imag * bb + 2 * g.real * cc]))
            b_rows.append(np.vstack([eye, np.zeros((m, m))]))
        if not blocks_a:
            return ContinuousSS(A=np.zeros((0, 0)), B=np.zeros((0, m)), C=np.zeros((m, 0)), D=d,
                                D1=self.a1.copy(), D2=self.a2.copy())
        n = sum(b.shape[0] for b in blocks_a)
        a = np.zeros((n, n))
        i = 0
        for blk in blocks_a:  # a few lag blocks
            a[i : i + blk.shape[0], i : i + blk.shape[0]] = blk
            i += blk.shape[0]
        return ContinuousSS(A=a, B=np.vstack(b_rows), C=np.hstack(blocks_c), D=d, D1=self.a1.copy(),
                            D2=self.a2.copy())


@dataclass
class RfaFit:
    """Result of :func:`fit_rfa`: the RFA, its weighted entry errors and the lag search it came from."""

    rfa: RogerRfa
    fit_error: np.ndarray  # [m, m] worst weighted error over the table, per entry
    max_error: float
    tol: float
    errors_by_lags: dict[int, float]  # best worst-entry error reached with n lag-state units


def _regressors(p: np.ndarray, lags: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """Complex regressors [n, 2 + nl + 2 np] of A1, A2, the real-lag and the complex-pair matrices at p [n]."""
    cols = [p, p * p]
    cols += [p / (p + b) for b in lags]
    for g in pairs:  # a few complex pairs
        g1, g2 = p / (p + g), p / (p + np.conj(g))
        cols += [g1 + g2, 1j * (g1 - g2)]
    return np.column_stack(cols)


def entry_scale(h: np.ndarray) -> np.ndarray:
    """Weight scale [m, m] of each entry: sqrt(max_k |H_ii| max_k |H_jj|) (floored at 1e-12 of the largest)."""
    diag = np.max(np.abs(np.diagonal(h, axis1=1, axis2=2)), axis=0)
    diag = np.maximum(diag, 1e-12 * max(float(np.max(np.abs(h))), 1e-300))
    return np.sqrt(np.outer(diag, diag))


def fit_errors(h_fit: np.ndarray, h: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """Worst weighted error over the table per entry, [m, m]."""
    return np.max(np.abs(h_fit - h), axis=0) / scale


def _solve(k: np.ndarray, h: np.ndarray, lags: np.ndarray, pairs: np.ndarray, a0: np.ndarray | None) -> RogerRfa:
    """Linear least squares of A1, A2 and the lag matrices (and A0 unless given) for fixed lag roots."""
    m = h.shape[1]
    reg = _regressors(2j * k, lags, pairs)
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
    nl = lags.size
    return RogerRfa(lags=lags.copy(), a0=np.array(a0), a1=mats[0], a2=mats[1], a_lag=mats[2 : 2 + nl],
                    pairs=pairs.copy(), a_pair=mats[2 + nl :].reshape(pairs.size, 2, m, m))


def _roots(x: np.ndarray, nl: int) -> tuple[np.ndarray, np.ndarray]:
    """Lag roots from optimizer variables: log beta [nl], then (log |gamma|, angle) per complex pair."""
    lags = np.sort(np.exp(x[:nl]))
    mag, ang = np.exp(x[nl::2]), x[nl + 1 :: 2]
    return lags, mag * np.exp(1j * ang)


def _objective(x: np.ndarray, nl: int, k: np.ndarray, h: np.ndarray, a0: np.ndarray | None,
               scale: np.ndarray) -> float:
    """Sum of squared weighted residuals for the lag roots encoded in x (variable projection)."""
    lags, pairs = _roots(x, nl)
    rfa = _solve(k, h, lags, pairs, a0)
    return float(np.sum(np.abs((rfa(k) - h) / scale) ** 2))


def configurations(max_units: int) -> list[tuple[int, int]]:
    """(real lags, complex pairs) to try, by increasing lag-state units nl + 2 np <= max_units."""
    return [(u - 2 * npair, npair) for u in range(max_units + 1) for npair in range(u // 2 + 1)]


def _start(nl: int, npair: int, k_max: float) -> tuple[np.ndarray, list[tuple[float, float]]]:
    """Start vector and bounds: real lags spread over 0.1 .. 1.2 of 2 k_max, pairs at 45 deg over 0.3 .. 1.5."""
    top = 2.0 * k_max
    lags = top * (np.geomspace(0.1, 1.2, nl) if nl > 1 else np.full(nl, 0.4))
    mags = top * (np.geomspace(0.3, 1.5, npair) if npair > 1 else np.full(npair, 0.7))
    x = np.concatenate([np.log(lags), np.column_stack([np.log(mags), np.full(npair, math.pi / 4)]).ravel()])
    log_b = (math.log(LAG_RANGE[0] * top), math.log(LAG_RANGE[1] * top))
    return x, [log_b] * nl + [log_b, (0.05, 0.5 * math.pi - 0.05)] * npair


def check_lag_settings(n_lags: Any, max_lags: Any, tol: Any, tol_field: str = "tol") -> None:
    """Validate the lag-choice settings of :func:`fit_rfa` (InputError naming the field): lag counts are integers
    in 0..12 (``n_lags`` may be None), the tolerance a finite number > 0 (named ``tol_field``)."""
    for name, v, optional in (("n_lags", n_lags, True), ("max_lags", max_lags, False)):
        if v is None and optional:
            continue
        if not (isinstance(v, int | np.integer) and not isinstance(v, bool) and 0 <= v <= 12):
            raise InputError(name, f"must be an integer in 0..12, got {v!r}")
    if not (isinstance(tol, int | float | np.floating) and not isinstance(tol, bool) and math.isfinite(tol)
            and tol > 0):
        raise InputError(tol_field, f"must be a finite number > 0, got {tol!r}")


def fit_rfa(
    k: np.ndarray,
    h: np.ndarray,
    *,
    n_lags: int | None = None,
    max_lags: int = DEFAULT_MAX_LAGS,
    tol: float = DEFAULT_TOL,
) -> RfaFit:
    """Fit a Roger RFA to the table H [nk, m, m] at reduced frequencies k [nk] (ascending, on the semichord).

    ``n_lags`` fixes the number of real lag roots (no complex pairs); None tries real lags and complex pairs by
    increasing state count up to ``max_lags`` units and keeps the first whose worst weighted entry error is
    below ``tol`` (else the best). Lag magnitudes are bounded to LAG_RANGE x 2 k_max (inside the table's range).
    InputError names the field for a bad table.
    """
    k = np.asarray(k, dtype=float)
    h = np.asarray(h, dtype=complex)
    if k.ndim != 1 or k.size < 3 or not np.all(np.isfinite(k)) or k[0] < 0 or np.any(np.diff(k) <= 0):
        raise InputError("k_values", "need at least 3 finite, ascending reduced frequencies >= 0")
    if h.ndim != 3 or h.shape[0] != k.size or h.shape[1] != h.shape[2] or not np.all(np.isfinite(h)):
        raise InputError("gaf", f"must be finite with shape ({k.size}, m, m), got {h.shape}")
    check_lag_settings(n_lags, max_lags, tol)
    a0 = h[0].real.copy() if k[0] == 0.0 else None
    n_free = 2 + (0 if a0 is not None else 1)
    n_data = 2 * (k.size - (1 if a0 is not None else 0))
    scale = entry_scale(h)
    configs = [(n_lags, 0)] if n_lags is not None else configurations(max_lags)
    best: tuple[float, RogerRfa] | None = None
    errors: dict[int, float] = {}
    for nl, npair in configs:
        units = nl + 2 * npair
        if n_free + units > n_data:
            break
        x0, bounds = _start(nl, npair, float(k[-1]))
        if units:
            x0 = minimize(_objective, x0, args=(nl, k, h, a0, scale), method="L-BFGS-B", bounds=bounds,
                          options={"maxiter": 300}).x
        rfa = _solve(k, h, *_roots(x0, nl), a0)
        err = float(np.max(fit_errors(rfa(k), h, scale)))
        errors[units] = min(err, errors.get(units, math.inf))
        if best is None or err < best[0]:
            best = (err, rfa)
        if n_lags is None and err <= tol:
            break
    if best is None:
        raise InputError("k_values", f"{k.size} reduced frequencies are too few to fit the RFA")
    rfa = best[1]
    fe = fit_errors(rfa(k), h, scale)
    return RfaFit(rfa=rfa, fit_error=fe, max_error=float(np.max(fe)), tol=float(tol), errors_by_lags=errors)
