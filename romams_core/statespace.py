"""State-space models of the aerodynamics in nondimensional time t* = t V / c_ref.

Discrete (ARX ROMs, step dt_star): x(n+1) = A x(n) + B u(n),  f(n) = C x(n) + D u(n).
Continuous (rational-function ROMs of frequency-domain solvers): dx/dt* = A x + B u,
f = C x + D u + D1 du/dt* + D2 d2u/dt*2. u generalized displacements, f GAC (m^3).
Tools: ARX realization, stability, balanced truncation, basis -> real modal coordinates, Tustin d2c.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import overload

import numpy as np
import scipy.linalg as sla

from romams_core.arx import ArxModel
from romams_core.errors import InputError

__all__ = [
    "DiscreteSS",
    "ContinuousSS",
    "arx_to_ss",
    "balanced_truncation",
    "band_gramians",
    "balanced_models",
    "to_modal",
    "d2c_tustin",
    "tustin_lu",
    "tustin_matrices",
    "spectral_radius",
    "eigenvector_condition",
    "vectors_condition",
    "diagonally_scaled",
    "DIAG_COND_MAX",
    "reflect_unstable_poles",
    "refit_output_map",
]


@dataclass
class DiscreteSS:
    """Discrete-time LTI model in t* (step dt_star): matrices A [n, n], B [n, m], C [p, n], D [p, m]."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    dt_star: float

    @property
    def n_states(self) -> int:
        """State dimension n."""
        return int(self.A.shape[0])

    @property
    def n_inputs(self) -> int:
        """Input dimension m."""
        return int(self.B.shape[1])

    @property
    def n_outputs(self) -> int:
        """Output dimension p."""
        return int(self.C.shape[0])

    def spectral_radius(self) -> float:
        """Largest pole magnitude |z| (0 for a static model)."""
        return spectral_radius(self.A)

    def is_stable(self, margin: float = 0.0) -> bool:
        """True when every pole satisfies |z| < 1 - margin."""
        return self.spectral_radius() < 1.0 - margin

    def simulate(self, u: np.ndarray, x0: np.ndarray | None = None) -> np.ndarray:
        """Output [T, p] for inputs u [T, m] from state x0 (default rest)."""
        u = np.asarray(u, dtype=float)
        x = np.zeros(self.n_states) if x0 is None else np.asarray(x0, dtype=float).copy()
        bu = u @ self.B.T
        xs = np.empty((u.shape[0], self.n_states))
        for t in range(u.shape[0]):  # sequential recursion
            xs[t] = x
            x = self.A @ x + bu[t]
        return xs @ self.C.T + u @ self.D.T

    def freqresp(self, k_values: np.ndarray) -> np.ndarray:
        """Transfer matrix [nk, p, m] at reduced frequencies k (on the semichord: z = exp(i 2 k dt_star))."""
        k_values = np.atleast_1d(np.asarray(k_values, dtype=float))
        out = np.empty((k_values.size, self.n_outputs, self.n_inputs), dtype=complex)
        eye = np.eye(self.n_states)
        for n, k in enumerate(k_values):  # a handful of frequencies
            z = np.exp(2j * k * self.dt_star)
            out[n] = self.C @ np.linalg.solve(z * eye - self.A, self.B) + self.D if self.n_states else self.D
        return out


@dataclass
class ContinuousSS:
    """Continuous-time LTI model with derivatives in t* (d/dt = (V / c_ref) d/dt*): A, B, C, D.

    ``D1`` and ``D2`` (optional, [p, m]) are the feedthrough of du/dt* and d2u/dt*2: the aerodynamic damping
    and apparent-mass terms of a rational function approximation, H(s*) = C (s* I - A)^-1 B + D + D1 s* + D2 s*^2.
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    D1: np.ndarray | None = None
    D2: np.ndarray | None = None

    @property
    def n_states(self) -> int:
        """State dimension n."""
        return int(self.A.shape[0])

    @property
    def n_inputs(self) -> int:
        """Input dimension m."""
        return int(self.D.shape[1])

    @property
    def n_outputs(self) -> int:
        """Output dimension p."""
        return int(self.D.shape[0])

    def transfer(self, s_star: np.ndarray) -> np.ndarray:
        """Transfer matrix [n, p, m] at complex nondimensional Laplace variables s* [n] (s* = s c_ref / V)."""
        s_star = np.atleast_1d(np.asarray(s_star, dtype=complex))
        eye = np.eye(self.n_states)
        out = np.empty((s_star.size, self.n_outputs, self.n_inputs), dtype=complex)
        for n, s in enumerate(s_star):  # a table of frequencies
            out[n] = self.D + (self.C @ np.linalg.solve(s * eye - self.A, self.B) if self.n_states else 0.0)
            if self.D1 is not None:
                out[n] += s * self.D1
            if self.D2 is not None:
                out[n] += s * s * self.D2
        return out

    def freqresp(self, k_values: np.ndarray) -> np.ndarray:
        """Transfer matrix [nk, p, m] at reduced frequencies k on the semichord (s* = i 2 k)."""
        return self.transfer(2j * np.atleast_1d(np.asarray(k_values, dtype=float)))

    def is_stable(self) -> bool:
        """True when every pole has a negative real part (a static model is stable)."""
        return bool(self.n_states == 0 or np.max(np.linalg.eigvals(self.A).real) < 0.0)


#: Eigenvector condition number above which a model is not diagonalized (the flutter search's fast path is not used).
DIAG_COND_MAX = 1e6


def vectors_condition(w: np.ndarray) -> float:
    """2-norm condition number of an eigenvector matrix ``w`` (dimensionless; inf when not finite, 1 if empty)."""
    if not w.size:
        return 1.0
    return float(np.linalg.cond(w)) if np.all(np.isfinite(w)) else math.inf


def eigenvector_condition(a: np.ndarray) -> float:
    """:func:`vectors_condition` of the eigenvectors of ``a``."""
    return vectors_condition(np.linalg.eig(a)[1]) if a.size else 1.0


def spectral_radius(a: np.ndarray) -> float:
    """max |eig(a)| (0 for an empty matrix)."""
    return float(np.max(np.abs(np.linalg.eigvals(a)))) if a.size else 0.0


def arx_to_ss(model: ArxModel, dt_star: float | None = None) -> DiscreteSS:
    """Realize an ARX model: state [f(n-1..n-na); u(n-1..n-nb+1)], C = [A_1..A_na, B_1..B_nb-1], D = B_0."""
    na, nb = model.na, model.nb
    p, m = model.b.shape[1], model.b.shape[2]
    nf, nu = na * p, (nb - 1) * m
    n = nf + nu
    c = np.hstack([*(model.a[i] for i in range(na)), *(model.b[i] for i in range(1, nb))]) if n else np.zeros((p, 0))
    d = model.b[0].copy()
    a = np.zeros((n, n))
    b = np.zeros((n, m))
    if na:
        a[:p, :] = c  # f(n) = C x + D u goes into the first f slot
        b[:p, :] = d
        a[p:nf, : nf - p] = np.eye(nf - p)
    if nb > 1:
        b[nf : nf + m, :] = np.eye(m)
        a[nf + m :, nf : n - m] = np.eye(nu - m)
    dt = model.dt_star if dt_star is None else dt_star
    return DiscreteSS(A=a, B=b, C=c, D=d, dt_star=float(dt))


def _psd_sqrt(w: np.ndarray) -> np.ndarray:
    """Square-root factor L with L L^T = w for a symmetric positive semidefinite matrix (eigen-based)."""
    w = 0.5 * (w + w.T)
    evals, evecs = np.linalg.eigh(w)
    return evecs * np.sqrt(np.clip(evals, 0.0, None))


def band_gramians(ss: DiscreteSS, k_band: float, n_quad: int = 128) -> tuple[np.ndarray, np.ndarray]:
    """Frequency-limited controllability and observability gramians over reduced frequencies |k| <= k_band.

    W_c = (1/2pi) int_-theta_max^theta_max X X^H dtheta with X = (e^{i theta} I - A)^-1 B, theta = 2 k dt_star,
    and W_o likewise with (e^{i theta} I - A)^-H C^H; Gauss-Legendre quadrature (``n_quad`` points) with
    triangular solves in the complex Schur basis of A.
    """
    if not (math.isfinite(k_band) and k_band > 0):
        raise InputError("k_band", f"must be a finite number > 0, got {k_band!r}")
    theta_max = min(math.pi, 2.0 * k_band * ss.dt_star)
    x, w = np.polynomial.legendre.leggauss(int(n_quad))
    theta = theta_max * x  # nodes on [-theta_max, theta_max]
    w = theta_max * w / (2.0 * math.pi)
    z = np.exp(1j * theta)
    n = ss.n_states
    # complex Schur form A = Q T Q^H: each node needs only triangular solves (A may be defective, as ARX is)
    t, q = sla.schur(ss.A.astype(complex), output="complex")
    bt = q.conj().T @ ss.B
    ct_h = (ss.C @ q).conj().T
    eye = np.eye(n)
    wc = np.zeros((n, n), dtype=complex)
    wo = np.zeros((n, n), dtype=complex)
    for zq, wt in zip(z, w, strict=True):  # quadrature nodes
        m = zq * eye - t
        xb = sla.solve_triangular(m, bt)
        yc = sla.solve_triangular(m, ct_h, trans=2)
        wc += wt * (xb @ xb.conj().T)
        wo += wt * (yc @ yc.conj().T)
    wc = (q @ wc @ q.conj().T).real
    wo = (q @ wo @ q.conj().T).real
    return 0.5 * (wc + wc.T), 0.5 * (wo + wo.T)


def balanced_truncation(
    ss: DiscreteSS, order: int | None = None, hsv_tol: float | None = None, k_band: float | None = None
) -> tuple[DiscreteSS, np.ndarray]:
    """Balanced truncation of a stable discrete model; returns (reduced model, Hankel singular values).

    Gramians from scipy.linalg.solve_discrete_lyapunov (or, with ``k_band``, frequency-limited gramians over
    |k| <= k_band, see :func:`band_gramians`), square-root balancing by eigen-factors and an SVD (works for
    non-minimal realizations such as ARX). Keep ``order`` states, or the states whose HSV exceed ``hsv_tol``
    times the largest (default 1e-8). Plain BT keeps stability and has H-infinity error <= 2 * sum(discarded
    HSV); the frequency-limited variant is far more accurate in band for the same order but guarantees
    neither, so its result must be checked (stability, validation error).
    """
    factors = _balancing_factors(ss, k_band)
    hsv = factors[1]
    if order is None:
        tol = 1e-8 if hsv_tol is None else float(hsv_tol)
        if not (math.isfinite(tol) and tol >= 0):
            raise InputError("hsv_tol", f"must be a finite number >= 0, got {hsv_tol!r}")
        order = int(np.sum(hsv > tol * hsv[0])) if hsv.size and hsv[0] > 0 else 0
    if not (isinstance(order, int | np.integer) and 0 <= order <= ss.n_states):
        raise InputError("order", f"must be an integer in [0, {ss.n_states}], got {order!r}")
    return _truncate(ss, factors, int(order)), hsv


def diagonally_scaled(ss: DiscreteSS) -> DiscreteSS:
    """The same model under the diagonal similarity (powers of 2, LAPACK gebal) that balances the row and column
    norms of A: exactly the same transfer matrix, far better scaled gramians for an ARX realization."""
    if ss.n_states == 0:
        return ss
    _, (s, _) = sla.matrix_balance(ss.A, permute=False, separate=True)
    return DiscreteSS(A=ss.A * s[None, :] / s[:, None], B=ss.B / s[:, None], C=ss.C * s[None, :], D=ss.D.copy(),
                      dt_star=ss.dt_star)


def balanced_models(
    ss: DiscreteSS, orders: list[int], k_band: float | None = None
) -> tuple[list[DiscreteSS], np.ndarray]:
    """Balanced truncations of ``ss`` at several orders from one balancing; returns (models, HSV)."""
    factors = _balancing_factors(ss, k_band)
    return [_truncate(ss, factors, int(r)) for r in orders], factors[1]


def _balancing_factors(ss: DiscreteSS, k_band: float | None) -> tuple[np.ndarray, ...]:
    """Square-root balancing data (U, HSV, V^T, L_c, L_o) of a stable model (plain or band-limited gramians)."""
    if not ss.is_stable():
        raise InputError("ss", f"balanced truncation needs a stable model (spectral radius {ss.spectral_radius():.6f})")
    if k_band is None:
        wc = sla.solve_discrete_lyapunov(ss.A, ss.B @ ss.B.T)
        wo = sla.solve_discrete_lyapunov(ss.A.T, ss.C.T @ ss.C)
    else:
        wc, wo = band_gramians(ss, k_band)
    lc, lo = _psd_sqrt(wc), _psd_sqrt(wo)
    u, hsv, vt = np.linalg.svd(lo.T @ lc)
    return u, hsv, vt, lc, lo


def _truncate(ss: DiscreteSS, factors: tuple[np.ndarray, ...], order: int) -> DiscreteSS:
    """Project ``ss`` on the leading ``order`` balanced states (capped at the numerically nonzero HSVs)."""
    u, hsv, vt, lc, lo = factors
    order = min(order, int(np.sum(hsv > 1e-14 * max(hsv[0], 1e-300)))) if hsv.size else 0
    s = 1.0 / np.sqrt(hsv[:order])
    t = lc @ vt[:order].T * s  # [n, r]
    ti = (s[:, None] * u[:, :order].T) @ lo.T  # [r, n]
    return DiscreteSS(A=ti @ ss.A @ t, B=ti @ ss.B, C=ss.C @ t, D=ss.D.copy(), dt_star=ss.dt_star)


def reflect_unstable_poles(ss: DiscreteSS) -> tuple[DiscreteSS, int]:
    """Stabilize by reflecting poles with |z| >= 1 to 1 / conj(z) (same phase); returns (model, count reflected).

    Works on the real Schur form A = Q T Q^T: a 1x1 block t -> 1/t, a 2x2 block of a complex pair is scaled
    by 1/|z|^2. B, C, D are unchanged. Meant for spurious, unexcited ARX poles (typically near z = -1);
    the caller must re-validate the model.
    """
    if ss.n_states == 0:
        return ss, 0
    t, q = sla.schur(ss.A, output="real")
    n = t.shape[0]
    count = 0
    i = 0
    while i < n:  # walk the diagonal blocks (a handful of unstable ones at most)
        if i + 1 < n and t[i + 1, i] != 0.0:
            blk = t[i : i + 2, i : i + 2]
            r = float(np.abs(np.linalg.eigvals(blk)[0]))
            if r >= 1.0:
                t[i : i + 2, i : i + 2] = blk / r**2
                count += 2
            i += 2
        else:
            if abs(t[i, i]) >= 1.0:
                t[i, i] = 1.0 / t[i, i]
                count += 1
            i += 1
    if count == 0:
        return ss, 0
    return DiscreteSS(A=q @ t @ q.T, B=ss.B.copy(), C=ss.C.copy(), D=ss.D.copy(), dt_star=ss.dt_star), count


def refit_output_map(ss: DiscreteSS, u: np.ndarray, y: np.ndarray) -> DiscreteSS:
    """Keep A, B; refit C, D by least squares so that the free-run output matches y [T, p] for inputs u [T, m].

    With A and B fixed the states are known, so the output map is linear: one least-squares solve with all
    outputs as right-hand sides (columns scaled to unit RMS). Used after pole reflection to move the zeros
    back into agreement with the moved poles.
    """
    u = np.asarray(u, dtype=float)
    y = np.asarray(y, dtype=float)
    x = np.zeros(ss.n_states)
    bu = u @ ss.B.T
    xs = np.empty((u.shape[0], ss.n_states))
    for t in range(u.shape[0]):  # sequential state recursion
        xs[t] = x
        x = ss.A @ x + bu[t]
    reg = np.hstack([xs, u])
    scale = np.sqrt(np.mean(reg**2, axis=0))
    scale[scale == 0] = 1.0
    theta = np.linalg.lstsq(reg / scale, y, rcond=None)[0]
    theta = theta / scale[:, None]  # [n + m, p]
    return DiscreteSS(A=ss.A.copy(), B=ss.B.copy(), C=theta[: ss.n_states].T.copy(), D=theta[ss.n_states :].T.copy(),
                      dt_star=ss.dt_star)


@overload
def to_modal(ss: DiscreteSS, gamma: np.ndarray) -> DiscreteSS: ...
@overload
def to_modal(ss: ContinuousSS, gamma: np.ndarray) -> ContinuousSS: ...
def to_modal(ss: DiscreteSS | ContinuousSS, gamma: np.ndarray) -> DiscreteSS | ContinuousSS:
    """Basis-coordinate model -> real modal coordinates: u = gamma xi, F = gamma^T f (gamma [m, k]), exact.

    Works on discrete and continuous models alike (a continuous model's D1, D2 transform like D).
    """
    gamma = np.asarray(gamma, dtype=float)
    if gamma.ndim != 2 or gamma.shape[0] != ss.n_inputs or ss.n_inputs != ss.n_outputs:
        raise InputError("gamma", f"expected shape [{ss.n_inputs}, k] for a square {ss.n_outputs}x{ss.n_inputs} model")
    if isinstance(ss, ContinuousSS):
        return ContinuousSS(A=ss.A.copy(), B=ss.B @ gamma, C=gamma.T @ ss.C, D=gamma.T @ ss.D @ gamma,
                            D1=None if ss.D1 is None else gamma.T @ ss.D1 @ gamma,
                            D2=None if ss.D2 is None else gamma.T @ ss.D2 @ gamma)
    return DiscreteSS(A=ss.A.copy(), B=ss.B @ gamma, C=gamma.T @ ss.C, D=gamma.T @ ss.D @ gamma, dt_star=ss.dt_star)


def tustin_lu(a: np.ndarray, field: str = "ss.A") -> tuple[np.ndarray, np.ndarray]:
    """LU factors of I + A (scipy.linalg.lu_factor); InputError naming ``field`` when A has a pole at z = -1."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sla.LinAlgWarning)  # an exactly singular I + A is refused below
        lu = sla.lu_factor(np.eye(a.shape[0]) + a)
    if np.min(np.abs(np.diag(lu[0]))) < 1e-12:
        raise InputError(field, "has a pole at z = -1; the Tustin (bilinear) map cannot convert it")
    return lu


def tustin_matrices(
    a: np.ndarray,
    b: np.ndarray,
    c: np.ndarray,
    d: np.ndarray,
    dt_star: float,
    lu: tuple[np.ndarray, np.ndarray] | None = None,
    abar: np.ndarray | None = None,
    field: str = "ss.A",
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Bilinear (Tustin) map of a discrete model in t* (step dt_star) to continuous time in t*, balanced form.

    With P = (I + A)^-1 and w0 = 2 / dt*: A_c = w0 (A - I) P, B_c = sqrt(2 w0) P B, C_c = sqrt(2 w0) C P,
    D_c = D - C P B (s* = w0 (z - 1)/(z + 1); frequencies warp as k_c = tan(k dt*) / dt*). ``lu`` (the LU
    factors of I + A) and ``abar`` (A_c) may be passed when already known (the flutter search caches them per
    ROM). A pole at z = -1 is refused (InputError naming ``field``). The one implementation of the map:
    :func:`d2c_tustin` and ``romams_core.flutter.tustin_to_continuous`` call it.
    """
    if a.shape[0] == 0:
        return a.copy(), b.copy(), c.copy(), d.copy()
    w0 = 2.0 / dt_star
    if lu is None:
        lu = tustin_lu(a, field)
    pb = sla.lu_solve(lu, b)
    cp = sla.lu_solve(lu, c.T, trans=1).T  # C P = (P^T C^T)^T
    if abar is None:
        eye = np.eye(a.shape[0])
        abar = w0 * (a - eye) @ sla.lu_solve(lu, eye)
    s = math.sqrt(2.0 * w0)
    return abar, s * pb, s * cp, d - c @ pb


def d2c_tustin(ss: DiscreteSS) -> ContinuousSS:
    """Bilinear (Tustin) map to continuous time in t*: s* = (2/dt*)(z-1)/(z+1); balanced B/C scaling.

    A_c = (2/dt*) (A - I)(I + A)^-1, B_c = sqrt(4/dt*) (I + A)^-1 B, C_c = sqrt(4/dt*) C (I + A)^-1,
    D_c = D - C (I + A)^-1 B (:func:`tustin_matrices`). A pole at z = -1 is refused (InputError naming ss.A).
    """
    a, b, c, d = tustin_matrices(ss.A, ss.B, ss.C, ss.D, ss.dt_star, field="ss.A")
    return ContinuousSS(A=a, B=b, C=c, D=d)
