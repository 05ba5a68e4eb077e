"""Minimal and modal realizations of discrete state-space models, by orthogonal transformations (no gramians).

An ARX realization (``statespace.arx_to_ss``) carries the delayed inputs as states. With na >= nb - 1 those are
not needed: the observer form of the same transfer matrix has na * p states. The surplus directions are
repeated, defective poles at z = 0, so the realization's eigenvectors are numerically singular and the flutter
search cannot diagonalize it. Balanced truncation finds the surplus only when the gramians are well scaled; on
a 10-shape TSD ROM their largest entries differ by 1e7 and the balancing lost the transfer matrix to 2.5 %. The
orthogonal staircase below removes the uncontrollable, then the unobservable directions without that loss
(1.4e-6 of the largest entry on that ROM), and the real modal form then makes the eigenvectors trivially
conditioned. docs/transonic.md 7.9.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from romams_core.statespace import DiscreteSS, diagonally_scaled

__all__ = ["krylov_basis", "minimal_realization", "real_modal_form"]

#: Rank tolerance of the staircase: singular values below this fraction of max(||A||, ||B||) are zero.
STAIRCASE_TOL = 1e-8


def krylov_basis(a: np.ndarray, b: np.ndarray, tol: float = STAIRCASE_TOL) -> np.ndarray:
    """Orthonormal basis [n, r] of the controllable subspace span{B, AB, A^2 B, ...} (block Krylov with deflation:
    each new block is orthogonalized twice against the basis and its rank decided by an SVD)."""
    n = a.shape[0]
    q = np.zeros((n, 0))
    scale = max(float(np.linalg.norm(a, 2)), float(np.linalg.norm(b, 2)), 1e-300)
    blk = b
    while q.shape[1] < n:  # at most n / rank(B) + 1 blocks
        for _ in range(2):
            blk = blk - q @ (q.T @ blk)
        u, s, _ = np.linalg.svd(blk, full_matrices=False)
        r = int(np.sum(s > tol * scale))
        if r == 0:
            break
        new = u[:, :r]
        q = np.hstack([q, new])
        blk = a @ new
    return q


def minimal_realization(ss: DiscreteSS, tol: float = STAIRCASE_TOL) -> DiscreteSS:
    """The controllable and observable part of ``ss`` (same transfer matrix; dimensionless, step dt_star): the
    model is diagonally scaled, then projected on its controllable subspace, then on the observable one."""
    if ss.n_states == 0:
        return ss
    sc = diagonally_scaled(ss)
    qc = krylov_basis(sc.A, sc.B, tol)
    a, b, c = qc.T @ sc.A @ qc, qc.T @ sc.B, sc.C @ qc
    qo = krylov_basis(a.T, c.T, tol)
    return DiscreteSS(A=qo.T @ a @ qo, B=qo.T @ b, C=c @ qo, D=ss.D.copy(), dt_star=ss.dt_star)


def real_modal_form(ss: DiscreteSS) -> tuple[DiscreteSS, float]:
    """``ss`` in real modal coordinates (A block diagonal: 1x1 real poles, 2x2 blocks [[s, w], [-w, s]] per
    complex pair) and the condition number of the transformation (inf when A is not diagonalizable); the
    transfer matrix is kept to about 1e-16 times that condition number."""
    if ss.n_states == 0:
        return ss, 1.0
    lam, w = np.linalg.eig(ss.A)
    if not np.all(np.isfinite(w)):
        return ss, float("inf")
    try:
        a_mod, t = sla.cdf2rdf(lam, w)
    except ValueError:  # conjugate pairs not adjacent: not expected from LAPACK's geev
        return ss, float("inf")
    cond = float(np.linalg.cond(t))
    if not np.isfinite(cond) or cond > 1e14:
        return ss, float("inf")
    return DiscreteSS(A=np.ascontiguousarray(a_mod), B=np.linalg.solve(t, ss.B), C=ss.C @ t, D=ss.D.copy(),
                      dt_star=ss.dt_star), cond
