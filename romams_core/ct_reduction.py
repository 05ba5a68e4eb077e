"""Balanced reduction of continuous-time aero models (the RFA realizations) by singular perturbation.

A Roger RFA of m shapes with n lag units has n m states, most of them weakly controllable or observable: the
flutter search's cost grows with the cube of the coupled system's size, so the realization is reduced once,
at training. Steps, for a stable model (A, B, C, D) in t* (D1, D2 pass through untouched):

1. gramians from the Lyapunov equations A Wc + Wc A^T + B B^T = 0, A^T Wo + Wo A + C^T C = 0
   (``scipy.linalg.solve_continuous_lyapunov``);
2. square-root balancing: Wc = Lc Lc^T, Wo = Lo Lo^T, Lo^T Lc = U S V^T; the states with Hankel singular values
   above 1e-12 of the largest form the balanced realization T = Lc V S^-1/2, T^-1 = S^-1/2 U^T Lo^T;
3. singular perturbation approximation to order r (the discarded states' derivatives set to zero):
   A_r = A11 - A12 A22^-1 A21, B_r = B1 - A12 A22^-1 B2, C_r = C1 - C2 A22^-1 A21, D_r = D - C2 A22^-1 B2.
   It keeps the steady value H(0) exact (the RFA's A0, so static aeroelastic results do not change), keeps
   stability, and its error is bounded by 2 x the sum of the discarded Hankel singular values at all frequencies.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from romams_core.errors import InputError
from romams_core.statespace import ContinuousSS, _psd_sqrt

__all__ = ["balanced_realization", "spa_reduce"]


def balanced_realization(ss: ContinuousSS) -> tuple[ContinuousSS, np.ndarray]:
    """Balanced minimal realization of a stable continuous model and its Hankel singular values (descending)."""
    a, b, c = ss.A, ss.B, ss.C
    if ss.n_states == 0:
        return ss, np.zeros(0)
    if not ss.is_stable():
        raise InputError("ss.A", "balanced reduction needs a stable model (every pole Re < 0)")
    wc = sla.solve_continuous_lyapunov(a, -b @ b.T)
    wo = sla.solve_continuous_lyapunov(a.T, -c.T @ c)
    lc, lo = _psd_sqrt(wc), _psd_sqrt(wo)
    u, s, vt = np.linalg.svd(lo.T @ lc)
    keep = int(np.sum(s > 1e-12 * s[0])) if s.size and s[0] > 0 else 0
    sq = np.sqrt(s[:keep])
    t = lc @ vt[:keep].T / sq
    ti = (u[:, :keep] / sq).T @ lo.T
    bal = ContinuousSS(A=ti @ a @ t, B=ti @ b, C=c @ t, D=ss.D.copy(), D1=ss.D1, D2=ss.D2)
    return bal, s


def spa_reduce(balanced: ContinuousSS, order: int) -> ContinuousSS:
    """Singular perturbation approximation of order ``order`` of a balanced model (steady value kept exact)."""
    n = balanced.n_states
    if not (isinstance(order, int | np.integer) and 0 <= order <= n):
        raise InputError("order", f"must be an integer in [0, {n}], got {order!r}")
    if order == n:
        return balanced
    r = int(order)
    a, b, c = balanced.A, balanced.B, balanced.C
    a22_a21 = np.linalg.solve(a[r:, r:], a[r:, :r])
    a22_b2 = np.linalg.solve(a[r:, r:], b[r:])
    return ContinuousSS(A=a[:r, :r] - a[:r, r:] @ a22_a21, B=b[:r] - a[:r, r:] @ a22_b2,
                        C=c[:, :r] - c[:, r:] @ a22_a21, D=balanced.D - c[:, r:] @ a22_b2,
                        D1=balanced.D1, D2=balanced.D2)
