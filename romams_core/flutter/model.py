"""The coupled aeroelastic model: aero preparation (cached per ROM), Tustin or zero-order-hold form.

Tustin (default): the discrete aero model is converted once to continuous time in t* by the bilinear map
(``romams_core.statespace.tustin_matrices``, the one implementation); in physical time its states obey
dx/dt = (V / c_ref)(Abar x + Bbar xi). When Abar is reliably diagonalizable (eigenvector condition number below
``DIAG_COND_MAX``) its eigen-decomposition is kept, so that the aero transfer matrix in physical time is
H(s) = Dbar + sum_i res_i vc / (s - vc lam_i) (vc = V / c_ref) and the eigen-solver can work with the k x k
matrix T(s) = s^2 I + s G + K - q H(s) (``eigen.py``). Zero-order hold: the discrete matrices are kept as they are.

Continuous aero models (``ContinuousSS``, the rational-function ROMs of frequency-domain solvers) are used as
they are by the default coupling (no map needed); their aerodynamic damping and apparent-mass terms D1, D2
(f += D1 du/dt* + D2 d2u/dt*2) enter T(s) as -q (s / vc) D1 - q (s / vc)^2 D2. The zero-order hold needs a
discrete model and refuses them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from romams_core.errors import InputError
from romams_core.statespace import DIAG_COND_MAX, tustin_lu, tustin_matrices, vectors_condition

from .inputs import aero_matrices


@dataclass(frozen=True)
class AeroPrep:
    """Structure-independent data of one aero state matrix A (cached per A).

    The ROMs of a wing are trained once in basis coordinates; per structure only B, C, D change
    (to_modal), so the spectral-radius check, the Tustin factorization and the eigen-decomposition of the
    continuous aero matrix are computed once per ROM.
    """

    radius: float  # spectral radius of A
    lu: Any  # LU factors of I + A (Tustin), None for zoh or na = 0
    abar: np.ndarray | None  # continuous aero matrix in t* (Tustin)
    lam: np.ndarray | None  # eigenvalues of abar [na] (None: not reliably diagonalizable)
    w: np.ndarray | None  # eigenvectors of abar [na, na]
    wi: np.ndarray | None  # inverse of w
    poles: np.ndarray  # aero poles in t* as continuous eigenvalues (Tustin: of abar; zoh: ln(z) / dt*, z != 0)
    clusters: list[np.ndarray] | None = None  # ``_pole_clusters`` of lam (None: none, or lam is None)


PREP_CACHE: dict[tuple[Any, ...], AeroPrep] = {}
PREP_CACHE_SIZE = 64


def _continuous_prep(a: np.ndarray) -> AeroPrep:
    """Structure-independent data of a continuous aero matrix ``a`` in t* (validated: every pole Re < 0)."""
    na = a.shape[0]
    if not na:
        return AeroPrep(0.0, None, a.copy(), np.zeros(0, complex), np.zeros((0, 0), complex),
                        np.zeros((0, 0), complex), np.zeros(0, complex))
    lam, w = np.linalg.eig(a)
    lam = lam.astype(complex)
    if np.max(lam.real) >= 0.0:
        raise InputError("aero.A", f"unstable aerodynamic model (pole with real part {np.max(lam.real):.6g} >= 0)")
    wi = None
    if vectors_condition(w) < DIAG_COND_MAX:
        wi, w = np.linalg.inv(w).astype(complex), w.astype(complex)
    return AeroPrep(float(np.max(np.abs(lam))), None, a.copy(), lam if wi is not None else None,
                    w if wi is not None else None, wi, lam, _pole_clusters(lam) if wi is not None else None)


def aero_prep(a: np.ndarray, dt_star: float, coupling: str) -> AeroPrep:
    """Cached structure-independent data of aero matrix ``a`` (validated: stable, Tustin-convertible).

    ``dt_star`` = 0 marks a continuous matrix in t* (used as it is by the "tustin" coupling).
    """
    key = (coupling, float(dt_star), a.shape, a.tobytes())
    prep = PREP_CACHE.get(key)
    if prep is not None:
        return prep
    if dt_star == 0.0:
        prep = _continuous_prep(a)
        _cache(key, prep)
        return prep
    na = a.shape[0]
    z = np.linalg.eigvals(a).astype(complex) if na else np.zeros(0, complex)
    rad = float(np.max(np.abs(z))) if na else 0.0
    if rad >= 1.0:
        raise InputError("aero.A", f"unstable aerodynamic model (spectral radius {rad:.6f} >= 1)")
    lu = abar = lam = w = wi = None
    nz = z[np.abs(z) > 1e-10]
    poles = np.log(nz) / dt_star  # zoh: continuous-time equivalents of the discrete poles (delays excluded)
    if coupling == "tustin":
        if na:
            lu = tustin_lu(a, "aero.A")
            abar = tustin_matrices(a, np.zeros((na, 0)), np.zeros((0, na)), np.zeros((0, 0)), dt_star, lu=lu)[0]
            lam, w = np.linalg.eig(abar)
            poles = lam.astype(complex)
            if vectors_condition(w) < DIAG_COND_MAX:
                lam, wi = lam.astype(complex), np.linalg.inv(w).astype(complex)
                w = w.astype(complex)
            else:
                lam = w = None
        else:
            abar, lam = np.zeros((0, 0)), np.zeros(0, complex)
            w, wi = np.zeros((0, 0), complex), np.zeros((0, 0), complex)
    prep = AeroPrep(rad, lu, abar, lam, w, wi, poles, None if lam is None else _pole_clusters(lam))
    _cache(key, prep)
    return prep


def _cache(key: tuple[Any, ...], prep: AeroPrep) -> None:
    """Store ``prep`` in the bounded PREP_CACHE (oldest entry dropped)."""
    if len(PREP_CACHE) >= PREP_CACHE_SIZE:
        PREP_CACHE.pop(next(iter(PREP_CACHE)))
    PREP_CACHE[key] = prep


@dataclass
class Model:
    """Prepared coupling data of one structure and one aero ROM."""

    k: int
    na: int
    omega: np.ndarray
    zeta: np.ndarray
    c_ref: float
    dt_star: float
    coupling: str
    a: np.ndarray  # aero matrices in the form the coupling uses (CT for tustin, DT for zoh)
    b: np.ndarray
    c: np.ndarray
    d: np.ndarray
    # diagonalized aero part (Tustin only; None: use the full eigenvectors): a = W diag(lam_a) W^-1 and the
    # pole residues res[i] = (c W)[:, i] (W^-1 b)[i, :] flattened [na, k*k], so
    # c (sI - a)^-1 b = sum_i res[i] / (s - lam_a[i])
    lam_a: np.ndarray | None = None
    res: np.ndarray | None = None
    base: np.ndarray | None = None  # sweep-independent part of the coupled matrix (Tustin), built on first use
    poles: np.ndarray = field(default_factory=lambda: np.zeros(0, complex))  # aero poles in t* (continuous)
    d1: np.ndarray | None = None  # [k, k] feedthrough of dxi/dt* (continuous aero models: aerodynamic damping)
    d2: np.ndarray | None = None  # [k, k] feedthrough of d2xi/dt*2 (continuous aero models: apparent mass)
    kernel: Any = None  # the arrays of the compiled kernels (``newton_kernel.model_args``)

    @property
    def min_speed(self) -> float:
        """Lowest speed (m/s) at which the coupling is meaningful: 0 for Tustin; for the zero-order hold the
        speed below which the highest structural mode aliases (omega_max dt > pi, dt = dt* c_ref / V)."""
        if self.coupling == "tustin":
            return 0.0
        return float(np.max(self.omega)) * self.dt_star * self.c_ref / np.pi

    @property
    def near_r(self) -> np.ndarray:
        """|1 / (s* - lam_i)| above which s* = s c_ref / V is within LAG_NEAR |lam_i| of aero pole i (fast path)."""
        from .eigen import LAG_NEAR

        assert self.lam_a is not None
        return 1.0 / (LAG_NEAR * np.abs(self.lam_a))

    def submodel(self, j: int) -> Model:
        """The 1-mode model of structural mode j with its own diagonal aero terms."""
        return Model(1, self.na, self.omega[[j]], self.zeta[[j]], self.c_ref, self.dt_star, self.coupling, self.a,
                     self.b[:, [j]], self.c[[j], :], self.d[[j]][:, [j]], self.lam_a,
                     None if self.res is None else self.res[:, [j * self.k + j]], None, self.poles,
                     None if self.d1 is None else self.d1[[j]][:, [j]],
                     None if self.d2 is None else self.d2[[j]][:, [j]])


MINIMAL_RTOL = 1e-11  # residue singular values below this x the largest one are dropped (minimal_realization)


def _pole_clusters(lam: np.ndarray) -> list[np.ndarray] | None:
    """Indices of equal poles (1e-9 relative), real poles and upper half-plane ones only (their conjugates are
    implied); None when the lower half-plane poles are not the conjugates of the upper ones, or there are none."""
    if lam.size == 0:  # an aero model without states (quasi-steady terms only)
        return None
    scale = 1e-9 * max(float(np.max(np.abs(lam))), 1e-300)
    real = np.abs(lam.imag) <= scale
    upper, lower = np.nonzero(~real & (lam.imag > 0))[0], np.nonzero(~real & (lam.imag < 0))[0]
    if upper.size != lower.size or not np.allclose(np.sort_complex(lam[upper]), np.sort_complex(lam[lower].conj()),
                                                   rtol=0, atol=scale):
        return None
    out: list[np.ndarray] = []
    for idx in (np.nonzero(real)[0], upper):
        idx = idx[np.lexsort((lam[idx].imag, lam[idx].real))]
        cut = np.nonzero(np.abs(np.diff(lam[idx])) > scale)[0] + 1
        out.extend(np.split(idx, cut) if idx.size else [])
    return out


def minimal_realization(lam: np.ndarray, w: np.ndarray, wi: np.ndarray, a: np.ndarray, b: np.ndarray,
                        c: np.ndarray, clusters: list[np.ndarray] | None
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(a, b, c) of the same transfer matrix c (sI - a)^-1 b without the states the modes neither drive nor see.

    a = w diag(lam) w^-1. A pole repeated d times (a rational-function ROM repeats every lag pole once per basis
    shape) contributes R / (s - lam) with R = (c w)_g (w^-1 b)_g of rank r <= min(d, k): it needs only r states
    (SVD of R; a complex pair 2r real states). Returns the input matrices when nothing can be removed (distinct
    poles: the ARX ROMs), so their searches are unchanged. ``clusters``: ``_pole_clusters(lam)``, computed once
    per ROM (``AeroPrep.clusters``).
    """
    if clusters is None or all(g.size == 1 for g in clusters):
        return a, b, c
    ct, bt = c @ w, wi @ b
    svds = [np.linalg.svd(ct[:, g] @ bt[g, :]) for g in clusters]
    tol = MINIMAL_RTOL * max(float(sv[1][0]) for sv in svds)
    blocks_a, blocks_b, blocks_c = [], [], []
    for g, (u, sv, vh) in zip(clusters, svds, strict=True):
        r = int(np.count_nonzero(sv > tol))
        p, q, lg = sv[:r, None] * vh[:r], u[:, :r], lam[g[0]]
        if abs(lg.imag) <= 1e-9 * abs(lg):
            blocks_a.append(lg.real * np.eye(r))
            blocks_b.append(p.real)
            blocks_c.append(q.real)
        else:  # z = x1 + i x2, z' = lam z + p u; the conjugate pole adds conj: y = 2 Re(q z)
            blocks_a.append(np.block([[lg.real * np.eye(r), -lg.imag * np.eye(r)],
                                      [lg.imag * np.eye(r), lg.real * np.eye(r)]]))
            blocks_b.append(np.vstack([p.real, p.imag]))
            blocks_c.append(np.hstack([2.0 * q.real, -2.0 * q.imag]))
    n = sum(x.shape[0] for x in blocks_a)
    if n >= a.shape[0]:
        return a, b, c
    am = np.zeros((n, n))
    i = 0
    for x in blocks_a:
        am[i:i + x.shape[0], i:i + x.shape[0]] = x
        i += x.shape[0]
    return am, np.vstack(blocks_b), np.hstack(blocks_c)


def make_model(om: np.ndarray, zt: np.ndarray, c_ref: float, aero: Any, coupling: str) -> Model:
    """Validated coupling data of structure (omega [k] rad/s, zeta [k]) and discrete aero model ``aero``."""
    k = om.size
    parts = aero_matrices(aero, k)
    a, b, c, d, dt_star = parts.a, parts.b, parts.c, parts.d, parts.dt_star
    if parts.continuous and coupling != "tustin":
        raise InputError("coupling", f"{coupling!r} needs a discrete-time aero model; a continuous one (a "
                                     "rational-function ROM) is coupled as it is by the default 'tustin'")
    prep = aero_prep(a, dt_star, coupling)
    lam_a = res = None
    if coupling == "tustin":
        if not parts.continuous:
            abar = None if prep.abar is None else prep.abar.copy()
            a, b, c, d = tustin_matrices(a, b, c, d, dt_star, lu=prep.lu, abar=abar, field="aero.A")
        if prep.lam is not None and prep.w is not None and prep.wi is not None:
            lam_a, res = prep.lam, ((c @ prep.w).T[:, :, None] * (prep.wi @ b)[:, None, :]).reshape(-1, k * k)
            a, b, c = minimal_realization(prep.lam, prep.w, prep.wi, a, b, c, prep.clusters)
    return Model(k, a.shape[0], om, zt, c_ref, dt_star, coupling, a, b, c, d, lam_a, res, None, prep.poles,
                 parts.d1, parts.d2)


def tustin_to_continuous(
    a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray, dt_star: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Bilinear (Tustin) map of a discrete model in t* (step dt_star) to continuous time in t* (balanced form).

    Thin alias of ``romams_core.statespace.tustin_matrices`` (kept for callers of the flutter module).
    """
    return tustin_matrices(np.asarray(a, float), np.asarray(b, float), np.asarray(c, float), np.asarray(d, float),
                           float(dt_star), field="aero.A")
