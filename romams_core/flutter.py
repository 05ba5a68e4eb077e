"""Aeroelastic coupling of a discrete-time aerodynamic ROM with modal structural dynamics; flutter search.

Structure (mass-normalized modes, M = I): xi'' + G xi' + K xi = q F, K = diag(omega^2), G = diag(2 zeta omega),
q = 0.5 rho V^2 (Pa), F = f (generalized force per unit q). The aerodynamic model is a discrete state
space in nondimensional time t* = t V / c_ref with step dt_star (x(n+1) = A x + B xi, f = C x + D xi),
already in real modal coordinates (u = xi).

Two couplings (every result is labelled with the one used):

- ``"tustin"`` (default): the aero model is converted once to continuous time in t* with the bilinear
  map, Abar = w0 (A - I) P, Bbar = sqrt(2 w0) P B, Cbar = sqrt(2 w0) C P, Dbar = D - C P B with
  P = (I + A)^-1 and w0 = 2 / dt_star; in physical time dx/dt = (V / c_ref)(Abar x + Bbar xi). The coupled
  matrix  [[0, I, 0], [-K + q Dbar, -G, q Cbar], [(V/c) Bbar, 0, (V/c) Abar]]  gives s directly, and a
  sweep only rescales blocks. Second-order accurate in dt_star (frequency warping ~ (k dt_star)^2 / 12).
- ``"zoh"`` (baseline): the structure is discretized exactly (zero-order hold, one augmented ``expm``)
  at dt = dt_star c_ref / V and coupled in discrete time with the ROM (feedthrough D included); the
  eigenvalues map back by s = ln(z) / dt after discarding z ~ 0. The held force lags by half a step,
  so the flutter speed converges to the Tustin one at first order in dt_star.

Damping conventions: zeta = -Re(s) / |s| (positive = stable) and g = 2 Re(s) / |s| = -2 zeta
(positive = unstable, as on NASTRAN-style V-g plots). Frequency omega = Im(s) (rad/s).

Three sweeps at fixed Mach (each result labelled): ``"constant-density"`` (V swept at rho_ref),
``"constant-speed"`` (V = M a_ref, density swept, i.e. only q changes; the paper's eq. 14, with the
paper's "flutter speed" sqrt(2 q_f / rho_ref)), ``"matched"`` (altitude swept with V = M a(h)).
Structural branches are tracked from their in-vacuo poles at q = 0 (Hungarian assignment on
(1 - MAC of the structural eigenvector part, normalized [xi; xi'/omega]) + weighted eigenvalue distance,
with local step halving when ambiguous), so aerodynamic-lag roots are never reported as flutter.
The first zero crossing of Re(s) on a structural branch is refined with ``scipy.optimize.brentq``.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.linalg
import scipy.linalg.lapack
from scipy.optimize import brentq, linear_sum_assignment

from romams_core.atmosphere import altitude_for_dynamic_pressure, isa, isa_table

SWEEPS = ("constant-density", "constant-speed", "matched")
COUPLINGS = ("tustin", "zoh")
DEFAULT_ALTITUDE_REF_M = 10_000.0
_zgesv = scipy.linalg.lapack.zgesv


@dataclass
class FlutterResult:
    """Flutter point and V-g / V-omega data of one Mach number (SI units, rad/s).

    ``v`` is the sweep's speed axis: true speed for constant-density and matched sweeps, the
    equivalent speed sqrt(2 q / rho_ref) for the constant-speed sweep (the paper's convention).
    ``g`` = 2 Re(s)/|s| (positive = unstable), ``zeta`` = -Re(s)/|s| (positive = stable), per structural
    branch [nv, k]; ``omega`` = Im(s) (rad/s). Scalars are None when no flutter was found.
    """

    mach: float
    sweep: str
    coupling: str
    flutter_found: bool
    v_flutter_m_s: float | None
    omega_flutter_rad_s: float | None
    q_flutter_pa: float | None
    rho_flutter: float | None
    altitude_m: float | None
    k_flutter: float | None  # omega_f * (c_ref / 2) / V_true: reduced frequency on the root semichord
    v_true_m_s: float | None  # physical speed at the flutter point
    flutter_mode: int | None  # 1-based index of the structural mode the flutter branch starts from
    sdoff: bool
    energy_share: float | None  # largest modal share of the flutter eigenvector ([xi; xi'/omega] norm)
    frequency_separation: float | None  # min relative frequency gap to another structural branch (info)
    single_mode_unstable: bool  # dominant mode alone unstable at q <= sdoff_q_factor q_f (checked if share high)
    message: str
    rho_ref: float
    a_ref: float
    c_ref: float
    dt_star: float
    v: np.ndarray = field(default_factory=lambda: np.zeros(0))  # [nv] m/s
    q: np.ndarray = field(default_factory=lambda: np.zeros(0))  # [nv] Pa
    rho: np.ndarray = field(default_factory=lambda: np.zeros(0))  # [nv] kg/m^3
    altitude: np.ndarray = field(default_factory=lambda: np.zeros(0))  # [nv] m (NaN unless matched)
    g: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))  # [nv, k]
    zeta: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))  # [nv, k]
    omega: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))  # [nv, k] rad/s
    modal_share: np.ndarray = field(default_factory=lambda: np.zeros(0))  # [k] shares of the flutter vector


# ----------------------------------------------------------------------------------------------
# input checks and model preparation
# ----------------------------------------------------------------------------------------------


def finite_positive(name: str, value: Any) -> float:
    """Return ``value`` as float or raise ValueError naming ``name`` unless finite and > 0."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: must be a number, got {value!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"{name}: must be finite and > 0, got {value!r}")
    return v


def check_flutter_inputs(
    omega: Any, zeta: Any, c_ref: Any, mach: Any, sweep: str
) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Validated (omega [k] rad/s, zeta [k], c_ref m, mach) of a flutter search; ValueError naming the field."""
    om = np.atleast_1d(np.asarray(omega, dtype=float))
    if om.ndim != 1 or om.size == 0 or not np.all(np.isfinite(om)) or np.any(om <= 0):
        raise ValueError("omega: must be a non-empty 1-D array of finite frequencies > 0 (rad/s)")
    k = om.size
    if zeta is None:
        zt = np.zeros(k)
    else:
        zt = np.broadcast_to(np.asarray(zeta, dtype=float), (k,)).copy() if np.ndim(zeta) == 0 else np.asarray(
            zeta, dtype=float)
        if zt.shape != (k,) or not np.all(np.isfinite(zt)) or np.any(zt < 0) or np.any(zt >= 1):
            raise ValueError(f"zeta: must be a scalar or [{k}] array of damping ratios in [0, 1)")
    c = finite_positive("c_ref", c_ref)
    if not (isinstance(mach, int | float | np.floating) and math.isfinite(mach) and mach >= 0):
        raise ValueError(f"mach: must be a finite number >= 0, got {mach!r}")
    if sweep != "constant-density" and mach <= 0:
        raise ValueError(f"mach: must be > 0 for the {sweep} sweep, got {mach!r}")
    return om, zt, c, float(mach)


def _aero_matrices(aero: Any, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float]:
    """Validated (A, B, C, D, dt_star) of a discrete aero model with k inputs and k outputs."""
    try:
        a, b, c, d = (np.asarray(getattr(aero, n), dtype=float) for n in ("A", "B", "C", "D"))
        dt_star = aero.dt_star
    except AttributeError as exc:
        raise ValueError(f"aero: needs attributes A, B, C, D, dt_star ({exc})") from None
    dt_star = finite_positive("aero.dt_star", dt_star)
    na = a.shape[0] if a.ndim == 2 else -1
    if a.ndim != 2 or a.shape != (na, na):
        raise ValueError(f"aero.A: must be square, got shape {a.shape}")
    if b.shape != (na, k):
        raise ValueError(f"aero.B: must have shape ({na}, {k}) for {k} structural modes, got {b.shape}")
    if c.shape != (k, na):
        raise ValueError(f"aero.C: must have shape ({k}, {na}) for {k} structural modes, got {c.shape}")
    if d.shape != (k, k):
        raise ValueError(f"aero.D: must have shape ({k}, {k}), got {d.shape}")
    for n, m in (("A", a), ("B", b), ("C", c), ("D", d)):
        if not np.all(np.isfinite(m)):
            raise ValueError(f"aero.{n}: contains non-finite values")
    return a, b, c, d, dt_star


@dataclass(frozen=True)
class _AeroPrep:
    """Structure-independent data of one aero state matrix A (internal, cached per A).

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


_PREP_CACHE: dict[tuple[Any, ...], _AeroPrep] = {}
_PREP_CACHE_SIZE = 64
_DIAG_COND_MAX = 1e6  # eigenvector condition number above which the fast (diagonalized) path is not used


def _aero_prep(a: np.ndarray, dt_star: float, coupling: str) -> _AeroPrep:
    """Cached structure-independent data of aero matrix ``a`` (validated: stable, Tustin-convertible)."""
    key = (coupling, float(dt_star), a.shape, a.tobytes())
    prep = _PREP_CACHE.get(key)
    if prep is not None:
        return prep
    na = a.shape[0]
    rad = float(np.max(np.abs(np.linalg.eigvals(a)))) if na else 0.0
    if rad >= 1.0:
        raise ValueError(f"aero.A: unstable aerodynamic model (spectral radius {rad:.6f} >= 1)")
    lu = abar = lam = w = wi = None
    if coupling == "tustin":
        if na:
            eye = np.eye(na)
            lu = scipy.linalg.lu_factor(eye + a)
            if np.min(np.abs(np.diag(lu[0]))) < 1e-12:
                raise ValueError("aero.A: has a pole at z = -1; the Tustin coupling cannot convert it")
            abar = (2.0 / dt_star) * (a - eye) @ scipy.linalg.lu_solve(lu, eye)
            lam, w = np.linalg.eig(abar)
            if np.all(np.isfinite(w)) and np.linalg.cond(w) < _DIAG_COND_MAX:
                lam, wi = lam.astype(complex), np.linalg.inv(w).astype(complex)
                w = w.astype(complex)
            else:
                lam = w = None
        else:
            abar, lam = np.zeros((0, 0)), np.zeros(0, complex)
            w, wi = np.zeros((0, 0), complex), np.zeros((0, 0), complex)
    prep = _AeroPrep(rad, lu, abar, lam, w, wi)
    if len(_PREP_CACHE) >= _PREP_CACHE_SIZE:
        _PREP_CACHE.pop(next(iter(_PREP_CACHE)))
    _PREP_CACHE[key] = prep
    return prep


def _tustin_from_prep(
    prep: _AeroPrep, a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray, dt_star: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """tustin_to_continuous with the cached factorization of I + A (same operations, same result)."""
    if a.shape[0] == 0:
        return a.copy(), b.copy(), c.copy(), d.copy()
    pb = scipy.linalg.lu_solve(prep.lu, b)
    cp = scipy.linalg.lu_solve(prep.lu, c.T, trans=1).T
    s = math.sqrt(2.0 * (2.0 / dt_star))
    return prep.abar.copy(), s * pb, s * cp, d - c @ pb


def tustin_to_continuous(
    a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray, dt_star: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Bilinear (Tustin) map of a discrete model in t* (step dt_star) to continuous time in t* (balanced form)."""
    na = a.shape[0]
    if na == 0:
        return a.copy(), b.copy(), c.copy(), d.copy()
    w0 = 2.0 / dt_star
    eye = np.eye(na)
    lu = scipy.linalg.lu_factor(eye + a)
    if np.min(np.abs(np.diag(lu[0]))) < 1e-12:
        raise ValueError("aero.A: has a pole at z = -1; the Tustin coupling cannot convert it")
    pb = scipy.linalg.lu_solve(lu, b)
    # C P = (P^T C^T)^T
    cp = scipy.linalg.lu_solve(lu, c.T, trans=1).T
    abar = w0 * (a - eye) @ scipy.linalg.lu_solve(lu, eye)
    s = math.sqrt(2.0 * w0)
    return abar, s * pb, s * cp, d - c @ pb


@functools.lru_cache(maxsize=64)
def _reference_state(altitude_m: float) -> tuple[float, float]:
    """(rho kg/m^3, a m/s) of the ISA at ``altitude_m`` (m), cached."""
    st = isa(altitude_m)
    return float(st.rho), float(st.a)


def _make_model(om: np.ndarray, zt: np.ndarray, c_ref: float, aero: Any, coupling: str) -> _Model:
    """Validated coupling data of structure (omega [k] rad/s, zeta [k]) and discrete aero model ``aero``."""
    k = om.size
    a, b, c, d, dt_star = _aero_matrices(aero, k)
    prep = _aero_prep(a, dt_star, coupling)
    lam_a = res = None
    if coupling == "tustin":
        a, b, c, d = _tustin_from_prep(prep, a, b, c, d, dt_star)
        if prep.lam is not None:
            lam_a, res = prep.lam, ((c @ prep.w).T[:, :, None] * (prep.wi @ b)[:, None, :]).reshape(-1, k * k)
    return _Model(k, a.shape[0], om, zt, c_ref, dt_star, coupling, a, b, c, d, lam_a, res)


@dataclass
class _Model:
    """Prepared coupling data (internal)."""

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

    def submodel(self, j: int) -> _Model:
        """The 1-mode model of structural mode j with its own diagonal aero terms."""
        return _Model(1, self.na, self.omega[[j]], self.zeta[[j]], self.c_ref, self.dt_star, self.coupling, self.a,
                      self.b[:, [j]], self.c[[j], :], self.d[[j]][:, [j]], self.lam_a,
                      None if self.res is None else self.res[:, [j * self.k + j]])


def _struct_vectors(m: _Model, lam: np.ndarray, v: np.ndarray, q: np.ndarray) -> np.ndarray | None:
    """Normalized structural eigenvector parts [xi; xi'/omega] [n, 2k, nt] of the Tustin eigenvalues lam [n, nt].

    xi spans the null space of T(s) = s^2 I + s G + K - q H(s), H(s) = Dbar + sum_i res_i vc / (s - vc lam_i)
    (vc = V / c_ref), and xi' = s xi; the aero states follow from xi. xi is found by one step of inverse
    iteration from a fixed generic vector: the null direction dominates by sigma_(k-1) / sigma_min, i.e. to
    rounding, since s is an eigenvalue. LAPACK lists a complex pair consecutively, positive imaginary part
    first; the second member takes the conjugate vector. None when ill-defined (non-finite, T exactly
    singular): the caller then uses the full eigenvectors.
    """
    k = m.k
    neg = lam.imag < 0
    paired = np.count_nonzero(neg[:, 1:] & (lam[:, 1:] == lam[:, :-1].conj())) == np.count_nonzero(neg)
    sel = ~neg if paired else np.ones(lam.shape, bool)  # not in LAPACK pair order: solve every eigenvalue
    rows = np.nonzero(sel)[0]
    ss = lam[sel]
    with np.errstate(all="ignore"):
        r = 1.0 / ((ss / (v / m.c_ref)[rows])[:, None] - m.lam_a)  # vc / (s - vc lam_i) [M, na]
        t = (m.d.ravel() + r @ m.res) * (-q[rows])[:, None]  # [M, k*k]
        t[:, :: k + 1] += (ss[:, None] + 2.0 * m.zeta * m.omega) * ss[:, None] + m.omega**2
        try:
            y = np.linalg.solve(t.reshape(-1, k, k), np.broadcast_to(_rhs(k), (ss.size, k, 1)))[..., 0]
        except np.linalg.LinAlgError:
            return None
        x = np.concatenate([y, (ss[:, None] / m.omega) * y], axis=1)
        x /= np.linalg.norm(x, axis=1, keepdims=True)
    if not np.isfinite(x).all():
        return None
    out = np.empty(lam.shape + (2 * k,), complex)
    out[sel] = x
    if paired:
        ip, jp = np.nonzero(neg)
        out[ip, jp] = out[ip, jp - 1].conj()
    return np.swapaxes(out, 1, 2)


def _normalized(xs: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """Structural eigenvector parts [n, 2k, nt] scaled to [xi; xi'/omega] with unit norm (zero columns stay 0)."""
    k = omega.size
    xs = np.concatenate([xs[:, :k], xs[:, k:] / omega[None, :, None]], axis=1)
    nrm = np.linalg.norm(xs, axis=1, keepdims=True)
    return xs / np.where(nrm > 0, nrm, 1.0)


@functools.lru_cache(maxsize=16)
def _rhs(k: int) -> np.ndarray:
    """Fixed generic complex start vector [k, 1] of the inverse iteration."""
    return ((1.0 + 0.37 * np.arange(k)) * np.exp(0.91j * np.arange(k)))[:, None]


class _NoRoot(Exception):
    """Newton on det T(s) did not converge (internal; the caller falls back to eigen-solves)."""


def _newton_root(m: _Model, vc: float, q: float, s0: complex, scale: float, maxit: int = 30) -> complex:
    """Eigenvalue s (rad/s) of the Tustin coupled system at V/c_ref = vc (1/s), q (Pa) by Newton on det T(s) from s0.

    Step: s <- s - 1 / tr(T^-1 dT/ds) (d ln det T / ds), dT/ds = 2 s I + G + (q / vc) sum_i res_i r_i^2 with
    r_i = vc / (s - vc lam_i); quadratic near a simple root, so a step below 1e-7 ``scale`` leaves an error of
    order 1e-14 ``scale``: converged. Raises _NoRoot otherwise.
    """
    k = m.k
    lam_a, res = m.lam_a, m.res
    g = 2.0 * m.zeta * m.omega
    kd = m.omega**2
    qd = -q * m.d.ravel()
    s = complex(s0)
    with np.errstate(all="ignore"):
        for _ in range(maxit):
            r = 1.0 / (s / vc - lam_a)
            t = qd - q * (r @ res)
            t[:: k + 1] += s * s + g * s + kd
            dt = (q / vc) * ((r * r) @ res)
            dt[:: k + 1] += 2.0 * s + g
            _, _, x, info = _zgesv(t.reshape(k, k), dt.reshape(k, k))
            if info > 0:
                return s  # T(s) exactly singular: s is an eigenvalue
            tr = complex(x.trace())
            if info < 0 or not (math.isfinite(tr.real) and math.isfinite(tr.imag)) or tr == 0:
                break
            step = 1.0 / tr
            s -= step
            if abs(step) <= 1e-7 * scale:
                return s
    raise _NoRoot(f"no convergence from {s0}")


def _eig_batch(m: _Model, v: np.ndarray, q: np.ndarray, vectors: bool = True) -> tuple[np.ndarray, Any, np.ndarray]:
    """Eigenvalues s [n, nt] (rad/s), normalized structural vectors [n, 2k, nt] ([xi; xi'/omega], None without
    vectors) and alias period (rad/s) [n]."""
    k, na = m.k, m.na
    n2 = 2 * k
    nv = v.size
    kk = np.diag(m.omega**2)
    gg = np.diag(2.0 * m.zeta * m.omega)
    vc = (v / m.c_ref)[:, None, None]
    qq = q[:, None, None]
    if m.coupling == "tustin":
        n = n2 + na
        if m.base is None:  # the sweep-independent entries
            m.base = np.zeros((n, n))
            m.base[:k, k:n2] = np.eye(k)
            m.base[k:n2, :k] = -kk
            m.base[k:n2, k:n2] = -gg
        ac = np.empty((nv, n, n))
        ac[:] = m.base
        ac[:, k:n2, :k] += qq * m.d
        ac[:, k:n2, n2:] = qq * m.c
        ac[:, n2:, :k] = vc * m.b
        ac[:, n2:, n2:] = vc * m.a
        per = np.full(nv, np.inf)
        if not vectors:
            return np.linalg.eigvals(ac).astype(complex), None, per
        if m.lam_a is not None:
            lam = np.linalg.eigvals(ac).astype(complex)
            xs = _struct_vectors(m, lam, v, q)
            if xs is not None:
                return lam, xs, per
        lam, vec = np.linalg.eig(ac)
        return lam.astype(complex), _normalized(vec[:, :n2, :], m.omega), per
    # zero-order hold: exact structure at dt, discrete coupling
    dt = m.dt_star * m.c_ref / v
    aug = np.zeros((nv, n2 + k, n2 + k))
    aug[:, :k, k:n2] = np.eye(k)
    aug[:, k:n2, :k] = -kk
    aug[:, k:n2, k:n2] = -gg
    aug[:, k:n2, n2:] = np.eye(k)
    aug *= dt[:, None, None]
    e = scipy.linalg.expm(aug)
    phi, gam = e[:, :n2, :n2], e[:, :n2, n2:]
    n = n2 + na
    ad = np.zeros((nv, n, n))
    ad[:, :n2, :n2] = phi
    ad[:, :n2, :k] += qq * (gam @ m.d)
    ad[:, :n2, n2:] = qq * (gam @ m.c)
    ad[:, n2:, :k] = m.b
    ad[:, n2:, n2:] = m.a
    if vectors:
        z, vec = np.linalg.eig(ad)
        xs = _normalized(vec[:, :n2, :], m.omega)
    else:
        z, xs = np.linalg.eigvals(ad), None
    z = z.astype(complex)
    small = np.abs(z) < 1e-10
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = np.log(np.where(small, 1.0, z)) / dt[:, None]
    lam[small] = np.nan
    return lam, xs, 2.0 * np.pi / dt


# ----------------------------------------------------------------------------------------------
# branch tracking
# ----------------------------------------------------------------------------------------------


@dataclass
class _Branches:
    """Tracked state of the k structural branches (internal)."""

    lam: np.ndarray  # [k] complex s
    vec: np.ndarray  # [2k, k] normalized structural vectors [xi; xi'/omega] (columns)


def _initial_branches(omega: np.ndarray, zeta: np.ndarray) -> _Branches:
    """In-vacuo structural poles (q = 0) and their structural eigenvectors."""
    k = omega.size
    lam = omega * (-zeta + 1j * np.sqrt(np.maximum(1.0 - zeta**2, 0.0)))
    a = np.concatenate([np.eye(k), np.diag(lam / omega)], axis=0).astype(complex)
    return _Branches(lam, a / np.linalg.norm(a, axis=0))


def _assign(
    prev: _Branches, lam_c: np.ndarray, a_c: np.ndarray, period: float, weight: float, omega: np.ndarray
) -> tuple[_Branches, float, float, float]:
    """One tracking step: Hungarian assignment of candidates (s, normalized structural vectors) to branches.

    Eigenvalue distances are relative to max(|s_prev|, omega_j) (a branch heading for s = 0 keeps a
    finite scale). Returns the new branch state, the smallest assigned MAC, the largest relative jump and
    the smallest margin of the next-best candidate over 1.5 x the assigned cost (< 0: near-tie).
    """
    k = prev.lam.size
    if math.isfinite(period):
        m = np.round((prev.lam.imag[:, None] - lam_c.imag[None, :]) / period)
        s = lam_c[None, :] + (1j * period) * m
    else:
        s = lam_c[None, :]
    mac = np.abs(prev.vec.conj().T @ a_c) ** 2
    dist = np.abs(s - prev.lam[:, None]) / np.maximum(np.abs(prev.lam), omega)[:, None]
    cost = (1.0 - mac) + weight * dist
    if not np.isfinite(cost).all():
        cost[~np.isfinite(cost)] = 1e6
    _, cols = linear_sum_assignment(cost)  # row indices come back sorted (k <= number of candidates)
    idx = np.arange(k)
    chosen = cost[idx, cols].tolist()
    new_lam = s[idx, cols] if s.shape[0] == k else lam_c[cols]
    # near-tie: the runner-up costs less than 1.5 x the assigned candidate (+0.002); a smaller step, where
    # the true continuation's cost tends to 0, separates them (e.g. an aero pole beside a mode). Only
    # lightly damped oscillatory branches are checked: a heavily damped pair splitting into two real
    # roots is a genuine, harmless tie. (Runner-up of a row: its second-smallest cost when the assigned
    # one is the smallest, else its smallest.)
    gap = math.inf
    if cost.shape[1] > 1:
        two = np.partition(cost, 1, axis=1)[:, :2].tolist()
        for j, (lj, wj) in enumerate(zip(prev.lam.tolist(), omega.tolist(), strict=True)):
            if lj.imag > 0.05 * wj and -lj.real < 0.25 * abs(lj):
                runner = two[j][1] if chosen[j] == two[j][0] else two[j][0]
                gap = min(gap, runner - 1.5 * chosen[j] - 0.002)
    return _Branches(new_lam, a_c[:, cols]), float(mac[idx, cols].min()), float(dist[idx, cols].max()), gap


class _Tracker:
    """Continuation of the structural branches along a scalar sweep parameter p (internal)."""

    def __init__(self, model: _Model, cond: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]], weight: float):
        self.m = model
        self.cond = cond
        self.weight = weight

    def eig(self, p: np.ndarray, vectors: bool = True) -> tuple[np.ndarray, Any, np.ndarray]:
        """Eigenvalues s, normalized structural vectors [n, 2k, nt] (None without vectors), alias periods."""
        v, rho = self.cond(p)
        return _eig_batch(self.m, v, 0.5 * rho * v**2, vectors)

    def step(self, prev: _Branches, p0: float, p1: float, lam1: np.ndarray, xs1: np.ndarray, per1: float,
             depth: int = 0) -> _Branches:
        """Track from p0 (state prev) to p1 (given eigen-data); an ambiguous step is split in four sub-steps
        (one batched eigen-solve of the three interior points), at most twice (1/16 of a step)."""
        new, mac_min, jump, gap = _assign(prev, lam1, xs1, per1, self.weight, self.m.omega)
        if (mac_min < 0.8 or jump > 1.0 or gap < 0.0) and depth < 2:
            ps = p0 + (p1 - p0) * np.array([0.25, 0.5, 0.75])
            lam_m, xs_m, per_m = self.eig(ps)
            state, pa = prev, p0
            for i in range(3):
                state = self.step(state, pa, ps[i], lam_m[i], xs_m[i], float(per_m[i]), depth + 1)
                pa = ps[i]
            return self.step(state, pa, p1, lam1, xs1, per1, depth + 1)
        return new


def _single_mode_unstable(
    m: _Model, cond: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]], j: int, p_start: float, p_end: float,
    weight: float, n: int = 6,
) -> bool:
    """True when structural mode j alone (diagonal aero term only) has an unstable oscillatory root at some p <= p_end.

    A zero-frequency (divergence) root of the single mode does not count: SDOFF is a dynamic instability.
    """
    if m.k == 1:
        return True
    sub = m.submodel(j)
    tr = _Tracker(sub, cond, weight)
    # fast path: no unstable oscillatory root at all at p_end -> stable (a single-mode hump that returns
    # to stability before p_end would be missed; such a hump is not flutter-critical at q_f anyway)
    lam_end, _, _ = tr.eig(np.array([p_end]), vectors=False)
    lam_end = lam_end[0]
    if not np.any((lam_end.real > 1e-9 * np.abs(lam_end)) & (np.abs(lam_end.imag) > 0.05 * sub.omega[0])):
        return False
    grid = np.linspace(p_start, p_end, n + 1)[1:]
    lam, xs, per = tr.eig(grid)
    state = _initial_branches(sub.omega, sub.zeta)
    p_prev = p_start
    for i in range(grid.size):
        state = tr.step(state, p_prev, grid[i], lam[i], xs[i], float(per[i]))
        s = state.lam[0]
        if s.real > 1e-9 * abs(s) and abs(s.imag) > 0.05 * sub.omega[0]:  # oscillatory (not divergence)
            return True
        p_prev = grid[i]
    return False


# ----------------------------------------------------------------------------------------------
# flutter analysis
# ----------------------------------------------------------------------------------------------


def _empty(mach: float, sweep: str, coupling: str, message: str, **kw: Any) -> dict[str, Any]:
    """Common keyword arguments of a FlutterResult without a flutter point."""
    base = dict(
        mach=mach, sweep=sweep, coupling=coupling, flutter_found=False, v_flutter_m_s=None,
        omega_flutter_rad_s=None, q_flutter_pa=None, rho_flutter=None, altitude_m=None, k_flutter=None,
        v_true_m_s=None, flutter_mode=None, sdoff=False, energy_share=None, frequency_separation=None,
        single_mode_unstable=False,
        message=message,
    )
    base.update(kw)
    return base


def flutter_analysis(
    omega: np.ndarray,
    aero: Any,
    c_ref: float,
    mach: float,
    *,
    sweep: str = "constant-speed",
    coupling: str = "tustin",
    zeta: np.ndarray | float | None = None,
    altitude_ref_m: float = DEFAULT_ALTITUDE_REF_M,
    rho_ref: float | None = None,
    a_ref: float | None = None,
    v_max: float | None = None,
    q_max: float | None = None,
    altitude_range_m: tuple[float, float] = (0.0, 20_000.0),
    n_points: int = 12,
    sdoff_share: float = 0.9,
    sdoff_q_factor: float = 1.1,
    track_weight: float = 0.5,
    rtol: float = 1e-4,
) -> FlutterResult:
    """Flutter search at one Mach number for structure ``omega`` [k] (rad/s) and modal aero ROM ``aero``.

    ``aero`` has A, B, C, D, dt_star (discrete, t* = t V / c_ref, inputs xi, outputs f = F / q);
    ``c_ref`` in m. Reference state: rho_ref, a_ref default to ISA at ``altitude_ref_m`` (10 km).
    Ranges: ``v_max`` (m/s, constant-density; default 3 M a_ref), ``q_max`` (Pa, constant-speed; default
    4 x 0.5 rho_ref (M a_ref)^2), ``altitude_range_m`` (matched). ``n_points`` coarse sweep points,
    refined with brentq to ``rtol`` relative. SDOFF when the flutter vector's largest modal share is
    >= ``sdoff_share`` AND that dominant mode alone (its own diagonal aero term, no coupling with the
    other modes) is already unstable at q <= ``sdoff_q_factor`` q_f. Returns a FlutterResult (no flutter in
    range is a result with flutter_found False).
    """
    if sweep not in SWEEPS:
        raise ValueError(f"sweep: must be one of {SWEEPS}, got {sweep!r}")
    if coupling not in COUPLINGS:
        raise ValueError(f"coupling: must be one of {COUPLINGS}, got {coupling!r}")
    om, zt, c_ref, mach = check_flutter_inputs(omega, zeta, c_ref, mach, sweep)
    k = om.size
    if not (isinstance(n_points, int | np.integer) and 4 <= n_points <= 2000):
        raise ValueError(f"n_points: must be an integer in [4, 2000], got {n_points!r}")
    if not (0.0 < sdoff_share <= 1.0):
        raise ValueError(f"sdoff_share: must be in (0, 1], got {sdoff_share!r}")
    if not (math.isfinite(sdoff_q_factor) and sdoff_q_factor >= 1.0):
        raise ValueError(f"sdoff_q_factor: must be >= 1, got {sdoff_q_factor!r}")
    model = _make_model(om, zt, c_ref, aero, coupling)
    dt_star = model.dt_star

    if rho_ref is None or a_ref is None:
        ref_rho, ref_a = _reference_state(float(altitude_ref_m))
    rho_ref = ref_rho if rho_ref is None else finite_positive("rho_ref", rho_ref)
    a_ref = ref_a if a_ref is None else finite_positive("a_ref", a_ref)

    # sweep parameter p: V (constant-density), q (constant-speed), or [-1, 0) bridge q-ramp at the
    # top altitude followed by p = h_top - h (matched); p = p_start is q = 0 where the branches start.
    if sweep == "constant-density":
        if v_max is None:
            if mach <= 0:
                raise ValueError("v_max: required for a constant-density sweep with mach = 0")
            v_max = 3.0 * mach * a_ref
        p_end = finite_positive("v_max", v_max)

        def cond(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            return np.asarray(p, float), np.full(np.shape(p), rho_ref)

        p_start, grid = 0.0, np.linspace(p_end / n_points, p_end, n_points)
    elif sweep == "constant-speed":
        v0 = mach * a_ref
        p_end = 4.0 * 0.5 * rho_ref * v0**2 if q_max is None else finite_positive("q_max", q_max)

        def cond(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            p = np.asarray(p, float)
            return np.full(p.shape, v0), 2.0 * p / v0**2

        p_start, grid = 0.0, np.linspace(p_end / n_points, p_end, n_points)
    else:
        h_lo, h_hi = (float(x) for x in altitude_range_m)
        if not (math.isfinite(h_lo) and math.isfinite(h_hi) and h_lo < h_hi):
            raise ValueError(f"altitude_range_m: must be (low, high) with low < high, got {altitude_range_m!r}")
        rho_top, a_top, _ = isa_table(h_hi)
        isa_table(h_lo)  # range check
        v_top, rho_top = mach * float(a_top), float(rho_top)

        def cond(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            p = np.asarray(p, float)
            rho_h, a_h, _ = isa_table(h_hi - np.maximum(p, 0.0))
            v = np.where(p < 0, v_top, mach * a_h)
            rho = np.where(p < 0, rho_top * (1.0 + np.minimum(p, 0.0)), rho_h)
            return v, rho

        p_start = -1.0
        grid = np.concatenate([np.linspace(-0.75, -0.25, 3), np.linspace(0.0, h_hi - h_lo, n_points)])

    tracker = _Tracker(model, cond, track_weight)
    lam_g, xs_g, per_g = tracker.eig(grid)
    state = _initial_branches(om, zt)
    lam_path = np.empty((grid.size, k), complex)
    states: list[_Branches] = []
    p_prev = p_start
    for i in range(grid.size):
        state = tracker.step(state, p_prev, grid[i], lam_g[i], xs_g[i], float(per_g[i]))
        lam_path[i] = state.lam
        states.append(state)
        p_prev = grid[i]

    # first zero crossing of Re(s) on any structural branch
    g_path = 2.0 * lam_path.real / np.abs(lam_path)
    unstable = g_path > 1e-9
    first = np.where(unstable.any(axis=0), unstable.argmax(axis=0), grid.size)
    i_cross = int(first.min())

    v_g, rho_g = cond(grid)
    q_g = 0.5 * rho_g * v_g**2
    keep = grid >= 0.0 if sweep == "matched" else np.ones(grid.size, bool)
    alt_g = np.where(keep, h_hi - grid, np.nan) if sweep == "matched" else np.full(grid.size, np.nan)
    v_axis = np.sqrt(2.0 * q_g / rho_ref) if sweep == "constant-speed" else v_g
    common = dict(
        rho_ref=rho_ref, a_ref=a_ref, c_ref=c_ref, dt_star=dt_star,
        v=v_axis[keep], q=q_g[keep], rho=rho_g[keep], altitude=alt_g[keep],
        g=g_path[keep], zeta=-0.5 * g_path[keep], omega=lam_path.imag[keep], modal_share=np.zeros(k),
    )
    if i_cross >= grid.size:
        rng = {
            "constant-density": f"V = {grid[-1]:.6g} m/s",
            "constant-speed": f"q = {grid[-1]:.6g} Pa",
            "matched": f"altitude down to {h_lo:.6g} m" if sweep == "matched" else "",
        }[sweep]
        return FlutterResult(**_empty(mach, sweep, coupling, f"no flutter up to {rng}", **common))

    if i_cross == 0:
        lo_p = p_start + 1e-6 * (grid[0] - p_start)
        lam_lo, xs_lo, per_lo = tracker.eig(np.array([lo_p]))
        lo_state = tracker.step(_initial_branches(om, zt), p_start, lo_p, lam_lo[0], xs_lo[0], float(per_lo[0]))
    else:
        lo_p, lo_state = grid[i_cross - 1], states[i_cross - 1]
    hi_p, hi_state = grid[i_cross], states[i_cross]

    def re_at(p: float, j_branch: int) -> float:
        """Re(s) of branch j_branch at p, matched to the bracket ends' linear prediction."""
        if p == lo_p:  # the bracket ends are known from the tracking
            return float(lo_state.lam[j_branch].real)
        if p == hi_p:
            return float(hi_state.lam[j_branch].real)
        lam, _, per = tracker.eig(np.array([p]), vectors=False)
        lam = lam[0]
        lam_a, lam_b = lo_state.lam[j_branch], hi_state.lam[j_branch]
        pred = lam_a + (p - lo_p) / (hi_p - lo_p) * (lam_b - lam_a)
        if math.isfinite(per[0]):
            lam = lam + 1j * per[0] * np.round((pred.imag - lam.imag) / per[0])
        j = int(np.nanargmin(np.abs(lam - pred)))
        return float(lam[j].real)

    def pred_at(p: float, j_branch: int) -> complex:
        """Linear prediction of branch j_branch's eigenvalue at p between the bracket ends."""
        lam_a, lam_b = lo_state.lam[j_branch], hi_state.lam[j_branch]
        return complex(lam_a + (p - lo_p) / (hi_p - lo_p) * (lam_b - lam_a))

    roots: dict[tuple[int, float], complex] = {}
    known: dict[int, list[tuple[float, complex]]] = {}

    def re_fast(p: float, j_branch: int) -> float:
        """re_at from Newton on det T(s) (no eigen-solve); raises _NoRoot.

        Newton starts from the linear interpolation between the nearest points of this branch already
        known on either side of p (the bracket ends, then brentq's earlier iterates).
        """
        if p == lo_p:
            return float(lo_state.lam[j_branch].real)
        if p == hi_p:
            return float(hi_state.lam[j_branch].real)
        pts = known.setdefault(j_branch, [(lo_p, complex(lo_state.lam[j_branch])),
                                           (hi_p, complex(hi_state.lam[j_branch]))])
        pa, sa = max((x for x in pts if x[0] < p), key=lambda x: x[0])
        pb, sb = min((x for x in pts if x[0] > p), key=lambda x: x[0])
        start = sa + (p - pa) / (pb - pa) * (sb - sa)
        v, rho = cond(np.array([p]))
        s = _newton_root(model, float(v[0]) / c_ref, 0.5 * float(rho[0]) * float(v[0]) ** 2, start,
                         max(abs(start), float(om[j_branch])))
        roots[(j_branch, p)] = s
        pts.append((p, s))
        return s.real

    # every branch that first goes unstable inside this interval is refined; the lowest crossing wins
    message = ""
    scale = max(abs(hi_p), abs(lo_p), 1e-300)
    cands = [int(jb) for jb in np.nonzero(first == i_cross)[0]]

    def refine(f: Callable[[float, int], float]) -> list[float]:
        """Crossing p of each candidate branch with the Re(s) function f (brentq to rtol)."""
        out = []
        for jb in cands:
            if f(lo_p, jb) > 0:
                out.append(lo_p)
            else:
                out.append(brentq(f, lo_p, hi_p, args=(jb,), xtol=rtol * scale * 1e-3, rtol=max(rtol, 1e-14)))
        return out

    eig_f = None
    if model.lam_a is not None:
        # fast path: brentq on Re(s) from Newton roots of det T(s); each crossing is then checked against a full
        # eigen-solve (the eigenvalue nearest to the prediction is the Newton root), else the eigen-solve path
        try:
            p_js = refine(re_fast)
        except _NoRoot:
            p_js = None
        if p_js is not None:
            chk = [(jb, pj) for jb, pj in zip(cands, p_js, strict=True) if pj != lo_p]
            if chk:
                lam_v, xs_v, per_v = tracker.eig(np.array([pj for _, pj in chk]))
                for i, (jb, pj) in enumerate(chk):
                    s = roots.get((jb, pj))
                    near = lam_v[i][int(np.nanargmin(np.abs(lam_v[i] - pred_at(pj, jb))))]
                    if s is None or abs(near - s) > 1e-8 * max(abs(s), float(om[jb])):
                        p_js = None
                        break
                    if pj == min(p_js):
                        eig_f = (lam_v[i:i + 1], xs_v[i:i + 1], per_v[i:i + 1])
    else:
        p_js = None
    if p_js is None:
        p_js, eig_f = refine(re_at), None
    p_f, branch = math.inf, -1
    for jb, pj in zip(cands, p_js, strict=True):
        if pj < p_f:
            p_f, branch = pj, jb
    if p_f == lo_p:
        message = "structural branch already unstable at the start of the sweep; "
    lam_f, xs_f, per_f = tracker.eig(np.array([p_f])) if eig_f is None else eig_f
    st_f = tracker.step(lo_state, lo_p, p_f, lam_f[0], xs_f[0], float(per_f[0]))
    lam_fl = complex(st_f.lam[branch])
    # modal shares of the flutter eigenvector, [xi; xi'/omega] normalization
    vec = st_f.vec[:, branch]
    share = np.abs(vec[:k]) ** 2 + np.abs(vec[k:]) ** 2
    share = share / share.sum()
    energy_share = float(share.max())
    # frequency separation from the other structural branches up to the flutter point (reported only)
    if k > 1:
        w_path = np.vstack([lam_path.imag[:i_cross], st_f.lam.imag[None, :]])
        wb = np.abs(w_path[:, branch])
        others = np.delete(w_path, branch, axis=1)
        sep = float(np.min(np.abs(others - w_path[:, [branch]]) / np.where(wb > 0, wb, 1.0)[:, None]))
    else:
        sep = math.inf
    v_f, rho_f = (float(x[0]) for x in cond(np.array([p_f])))
    q_f = 0.5 * rho_f * v_f**2
    single_unstable = False
    if energy_share >= sdoff_share:
        if sweep == "constant-density":
            p_chk = p_f * math.sqrt(sdoff_q_factor)
        elif sweep == "constant-speed":
            p_chk = p_f * sdoff_q_factor
        else:
            h_chk = altitude_for_dynamic_pressure(q_f * sdoff_q_factor, mach, clamp=True)
            p_chk = max(h_hi - h_chk, p_f)
        if i_cross == 0:  # unstable from the start: growth at p_f ~ 0 is too small to see, use the first point
            p_chk = max(p_chk, float(grid[0]))
        dominant = int(np.argmax(share))
        single_unstable = _single_mode_unstable(model, cond, dominant, p_start, p_chk, track_weight)
    sdoff = bool(energy_share >= sdoff_share and single_unstable)

    omega_f = abs(lam_fl.imag)
    alt_f = None
    if sweep == "matched":
        alt_f = float(h_hi - max(p_f, 0.0))
        if p_f < 0:
            message += f"unstable already at the top altitude {h_hi:.6g} m (flutter altitude above the range); "
    v_report = math.sqrt(2.0 * q_f / rho_ref) if sweep == "constant-speed" else v_f
    if omega_f <= 1e-6 * float(om.max()):
        message += "zero-frequency crossing (static divergence); "
    message += (
        f"flutter on structural branch {branch + 1} at q = {q_f:.6g} Pa, V = {v_f:.6g} m/s, "
        f"omega = {omega_f:.6g} rad/s ({sweep}, {coupling})"
    )
    common["modal_share"] = share
    return FlutterResult(
        mach=mach, sweep=sweep, coupling=coupling, flutter_found=True, v_flutter_m_s=v_report,
        omega_flutter_rad_s=omega_f, q_flutter_pa=q_f, rho_flutter=rho_f, altitude_m=alt_f,
        k_flutter=omega_f * 0.5 * c_ref / v_f, v_true_m_s=v_f, flutter_mode=branch + 1, sdoff=sdoff,
        single_mode_unstable=bool(single_unstable), energy_share=energy_share, frequency_separation=sep,
        message=message, **common,
    )
