"""Batched eigen-solves of the coupled system: eigenvalues, structural vectors, structural content.

For n sweep points (V [n], q [n]) one call stacks the n coupled matrices and solves them with one LAPACK
call. Every eigenvalue s (rad/s) comes with

- its structural eigenvector part [xi; xi'/omega], unit norm (``xs`` [n, 2k, nt]), which the branch tracker
  compares by MAC (aero states are excluded: their scaling is arbitrary);
- its structural content (``content`` [n, nt], 0..1): the share of the structural states in the eigenvalue's
  participation, |P_s| / (|P_s| + |P_a|) with P_s = sum over structural states of w_i v_i (w the left, v the
  right eigenvector, w^H v = 1) and P_a the same over the aero states. Participations are invariant under any
  change of the aero state coordinates, so the measure does not depend on the ROM's realization. A structural
  root has content near 1; an aerodynamic lag root (s ~ (V / c_ref) lam_a, the ROM's own dynamics, moved little
  by the structure) has content near 0;
- the lag-root mask (``lag`` [n, nt]): content below ``CONTENT_MIN`` AND s within ``LAG_NEAR`` (relative) of an
  aero pole (V / c_ref) lam_a. The second condition keeps a structural root near s = 0 (a divergence), whose
  participation is aerodynamic too (P_s = eta^H (2 s + G) xi vanishes with s when G = 0), from being taken
  for a lag root: the aero poles of a stable ROM lie far from s = 0 at any speed that matters.

Fast path (Tustin, diagonalizable aero matrix): LAPACK eigenvalues only; for each eigenvalue the right and
left null vectors xi, eta of T(s) = s^2 I + s G + K - q H(s) (one inverse-iteration step each, k x k) give
xs = [xi; s xi] and, with the aero states eliminated, P_s = eta^H (2 s I + G) xi / (eta^H T'(s) xi) and
P_a = -q eta^H H'(s) xi / (eta^H T'(s) xi). The D1, D2 terms of a continuous aero model change the structural
mass and damping (no aero states): their derivative counts in P_s, as the full eigenvectors' participation of
[xi; xi'] does. Reference path (defective aero matrix, zero-order hold): LAPACK
eigenvectors V and the left ones from V^-1.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from . import newton_kernel as nk
from .model import Model

CONTENT_MIN = 0.1  # structural content below this (and near an aero pole): an aerodynamic lag root
LAG_NEAR = 0.25  # |s / vc - lam_a| / |lam_a| below this: near that aero pole


@dataclass
class EigData:
    """Eigen-data of n sweep points: s [n, nt] (rad/s, NaN for discarded ZOH roots), structural vectors
    [n, 2k, nt] (None when not asked for), structural content [n, nt] (None without vectors) and the ZOH alias
    period [n] (inf for Tustin)."""

    lam: np.ndarray
    xs: np.ndarray | None
    content: np.ndarray | None
    period: np.ndarray
    lag: np.ndarray | None = None  # [n, nt] lag-root mask (None without vectors)
    x: np.ndarray | None = None  # [n] continuation coordinate of the points (set by the tracker)

    def point(self, i: int) -> EigData:
        """The data of sweep point i alone (leading axis of length 1)."""
        sl = slice(i, i + 1)
        return EigData(self.lam[sl], None if self.xs is None else self.xs[sl],
                       None if self.content is None else self.content[sl], self.period[sl],
                       None if self.lag is None else self.lag[sl], None if self.x is None else self.x[sl])


@functools.lru_cache(maxsize=16)
def _rhs(k: int) -> np.ndarray:
    """Fixed generic complex start vector [k, 1] of the inverse iteration."""
    return ((1.0 + 0.37 * np.arange(k)) * np.exp(0.91j * np.arange(k)))[:, None]


def normalized(xs: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """Structural eigenvector parts [n, 2k, nt] scaled to [xi; xi'/omega] with unit norm (zero columns stay 0)."""
    k = omega.size
    xs = np.concatenate([xs[:, :k], xs[:, k:] / omega[None, :, None]], axis=1)
    nrm = np.linalg.norm(xs, axis=1, keepdims=True)
    return xs / np.where(nrm > 0, nrm, 1.0)


def _pair_selection(lam: np.ndarray) -> tuple[np.ndarray, bool]:
    """Eigenvalues to solve for: the first member of each LAPACK conjugate pair (when listed pairwise)."""
    neg = lam.imag < 0
    paired = np.count_nonzero(neg[:, 1:] & (lam[:, 1:] == lam[:, :-1].conj())) == np.count_nonzero(neg)
    return (~neg if paired else np.ones(lam.shape, bool)), paired


def _rate_terms(
    m: Model, s: np.ndarray, vc: np.ndarray, q: np.ndarray
) -> tuple[np.ndarray, np.ndarray] | tuple[None, None]:
    """Contributions [n, k*k] of the D1, D2 terms of a continuous aero model to T(s) and dT/ds at s [n] (rad/s).

    -q (s / vc) D1 - q (s / vc)^2 D2 and its derivative -q (D1 / vc + 2 s D2 / vc^2); (None, None) without them.
    """
    if m.d1 is None and m.d2 is None:
        return None, None
    k2 = m.k * m.k
    sv = (s / vc)[:, None]
    qv = (q / vc)[:, None]
    d1 = np.zeros(k2) if m.d1 is None else m.d1.ravel()
    d2 = np.zeros(k2) if m.d2 is None else m.d2.ravel()
    return -q[:, None] * (sv * d1 + sv * sv * d2), -qv * (d1 + 2.0 * sv * d2)


Resolvent = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]


def resolvent_terms(m: Model, sstar: np.ndarray) -> Resolvent:
    """C (s* I - A)^-1 B and C (s* I - A)^-2 B [M, k*k] (flattened) of the Tustin aero model at s* = s c_ref / V [M],
    whether s* sits exactly on an aero pole [M] (both terms 0 there) and whether it is within ``LAG_NEAR`` of one [M].

    From the pole residues when the aero matrix is diagonalized (H - D = sum_i res_i / (s* - lam_i)); else (the
    reference path: defective aero matrix) by dense solves with s* I - A.
    """
    if m.lam_a is not None and m.res is not None:
        return resolvent_diag(sstar, m.lam_a, m.res)
    return resolvent_dense(sstar, m.a, m.b, m.c, m.poles)


def resolvent_diag(sstar: np.ndarray, lam_a: np.ndarray, res: np.ndarray) -> Resolvent:
    """``resolvent_terms`` from poles lam_a [na] or [M, na] and residues res [na, k*k] or [M, na, k*k]."""
    r = 1.0 / (sstar[:, None] - lam_a)  # [M, na]
    # a root exactly on an aero pole is an aero state the structure does not drive or see (a repeated pole of
    # an RFA ROM has more copies than modes): a pure aero root, structural part 0, content 0, a lag root
    on_pole = ~np.isfinite(r).all(axis=1)
    r[on_pole] = 0.0
    near = (np.abs(r) > 1.0 / (LAG_NEAR * np.abs(lam_a))).any(axis=1) | on_pole  # |s* - lam_i| < LAG_NEAR |lam_i|
    if res.ndim == 2:
        return r @ res, (r * r) @ res, on_pole, near
    return (r[:, None, :] @ res)[:, 0, :], ((r * r)[:, None, :] @ res)[:, 0, :], on_pole, near


def resolvent_dense(sstar: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray,
                    poles: np.ndarray) -> Resolvent:
    """``resolvent_terms`` by dense solves: a [na, na] or [M, na, na], b, c likewise, poles [np] or [M, np]."""
    n = sstar.size
    shifted = sstar[:, None, None] * np.eye(a.shape[-1]) - a  # [M, na, na]
    x = np.linalg.solve(shifted, np.broadcast_to(b, (n,) + b.shape[-2:]))  # (s* I - A)^-1 B
    h1 = (c @ x).reshape(n, -1)
    h2 = (c @ np.linalg.solve(shifted, x)).reshape(n, -1)
    on_pole = ~(np.isfinite(h1).all(axis=1) & np.isfinite(h2).all(axis=1))
    h1[on_pole] = 0.0
    h2[on_pole] = 0.0
    near = on_pole.copy()
    if poles.shape[-1]:
        near |= (np.abs(sstar[:, None] - poles) < LAG_NEAR * np.abs(poles)).any(axis=1)
    return h1, h2, on_pole, near


def null_vectors(t: np.ndarray, ss: np.ndarray, g: np.ndarray, omega: np.ndarray, dta: np.ndarray,
                 dt_rate: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Normalized structural vectors [xi; s xi / omega] [M, 2k] and structural content [M] of roots ss [M] (rad/s)
    from T(ss) [M, k*k], the aero states' part of dT/ds dta = -q dH_lag/ds [M, k*k] and the D1, D2 part dt_rate
    (``struct_vectors``); g = 2 zeta omega and omega [k] or [M, k]. NaN rows where T is exactly singular."""
    k = omega.shape[-1]
    t3 = t.reshape(-1, k, k)
    try:
        ti = np.linalg.inv(t3)  # T^-1 ~ xi eta^H / sigma_min: right and left null vectors
    except np.linalg.LinAlgError:  # one at a time, so that an exactly singular T spoils only its own row (NaN)
        ti = np.full(t3.shape, np.nan, complex)
        for i in range(t3.shape[0]):
            try:
                ti[i] = np.linalg.inv(t3[i])
            except np.linalg.LinAlgError:
                pass
    rhs = _rhs(k)
    y = (ti @ rhs)[..., 0]  # xi (one inverse-iteration step)
    zc = (rhs.conj().T @ ti)[:, 0, :]  # eta^H
    x = np.concatenate([y, (ss[:, None] / omega) * y], axis=1)
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    dts = (2.0 * ss[:, None] + g) * y  # structural part of dT/ds applied to xi
    if dt_rate is not None:  # D1, D2 act on the structural states (mass and damping): structural participation
        dts = dts + (dt_rate.reshape(-1, k, k) @ y[:, :, None])[:, :, 0]
    ps = np.abs(np.sum(zc * dts, axis=1))
    pa = np.abs((zc[:, None, :] @ (dta.reshape(-1, k, k) @ y[:, :, None]))[:, 0, 0])
    return x, ps / (ps + pa)


def struct_vectors(
    m: Model, lam: np.ndarray, v: np.ndarray, q: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Normalized structural parts [xi; xi'/omega] [n, 2k, nt], structural content [n, nt] and lag-root mask
    [n, nt] of the Tustin eigenvalues lam [n, nt] from the null vectors of T(s) (module docstring).

    xi is found by one step of inverse iteration from a fixed generic vector: the null direction dominates by
    sigma_(k-1) / sigma_min, i.e. to rounding, since s is an eigenvalue; likewise eta from the rows (both from one
    batched inverse of T, which is then dominated by xi eta^H / sigma_min). LAPACK lists
    a complex pair consecutively, positive imaginary part first; the second member takes the conjugate vector.
    A root exactly on an aero pole (an aero state the structure neither drives nor sees, e.g. the extra copies of
    a repeated RFA pole) is a pure aero root: structural part 0, content 0, lag root (as its full eigenvector).
    None when ill-defined (non-finite, T exactly singular): the caller then uses the full eigenvectors.
    """
    k = m.k
    sel, paired = _pair_selection(lam)
    rows = np.nonzero(sel)[0]
    ss = lam[sel]
    if m.lam_a is not None and nk.ENABLED:  # diagonalized aero matrix: the compiled null vectors (newton_kernel)
        x, cont, lag, ok = nk.vectors(np.ascontiguousarray(ss, complex), np.ascontiguousarray((v / m.c_ref)[rows]),
                                      np.ascontiguousarray(q[rows], float), *nk.model_args(m), CONTENT_MIN)
        return _fill_pairs(lam.shape, sel, paired, x, cont, lag) if ok else None
    with np.errstate(all="ignore"):
        vc = (v / m.c_ref)[rows]
        h1, h2, on_pole, near = resolvent_terms(m, ss / vc)
        t = (m.d.ravel() + h1) * (-q[rows])[:, None]  # h1 = H - D, h2 = -vc dH/ds
        g = 2.0 * m.zeta * m.omega
        t[:, :: k + 1] += (ss[:, None] + g) * ss[:, None] + m.omega**2
        t_rate, dt_rate = _rate_terms(m, ss, vc, q[rows])
        if t_rate is not None:
            t += t_rate
        dta = h2 * (q[rows] / vc)[:, None]  # -q dH_lag/ds (the aero states' part of dT/ds)
        x, cont = null_vectors(t, ss, g, m.omega, dta, dt_rate)
        x[on_pole] = 0.0
        cont[on_pole] = 0.0
    if not (np.isfinite(x).all() and np.isfinite(cont).all()):
        return None
    return _fill_pairs(lam.shape, sel, paired, x, cont, near & (cont < CONTENT_MIN))


def _fill_pairs(shape: tuple[int, ...], sel: np.ndarray, paired: bool, x: np.ndarray, cont: np.ndarray,
                lag: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vectors [n, 2k, nt], content and lag mask [n, nt] of all roots from those of the selected ones (the second
    member of a LAPACK conjugate pair takes the conjugate vector, the same content and lag flag)."""
    lagm = np.zeros(shape, bool)
    lagm[sel] = lag
    out = np.empty(shape + (x.shape[1],), complex)
    out[sel] = x
    content = np.empty(shape)
    content[sel] = cont
    if paired:
        ip, jp = np.nonzero(~sel)
        out[ip, jp] = out[ip, jp - 1].conj()
        content[ip, jp] = content[ip, jp - 1]
        lagm[ip, jp] = lagm[ip, jp - 1]
    return np.swapaxes(out, 1, 2), content, lagm


def _full_vectors(vec: np.ndarray, omega: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Normalized structural parts and structural content of full LAPACK eigenvectors vec [n, N, N]."""
    n2 = 2 * omega.size
    with np.errstate(all="ignore"):
        try:
            wl = np.linalg.inv(vec)  # rows: left eigenvectors with w^H v = 1
        except np.linalg.LinAlgError:
            wl = np.linalg.pinv(vec)
        part = np.swapaxes(wl, 1, 2) * vec  # [n, state, eig]: w_state v_state
        ps = np.abs(part[:, :n2].sum(axis=1))
        pa = np.abs(part[:, n2:].sum(axis=1))
        content = np.where(ps + pa > 0, ps / (ps + pa), 0.0)
    return normalized(vec[:, :n2, :], omega), np.nan_to_num(content)


def _tustin_matrices(m: Model, v: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Coupled first-order matrices [n, N, N] of the Tustin coupling (states [xi; xi'; x])."""
    k, na = m.k, m.na
    n2 = 2 * k
    n = n2 + na
    if m.base is None:  # the sweep-independent entries
        m.base = np.zeros((n, n))
        m.base[:k, k:n2] = np.eye(k)
        m.base[k:n2, :k] = -np.diag(m.omega**2)
        m.base[k:n2, k:n2] = -np.diag(2.0 * m.zeta * m.omega)
    vc = (v / m.c_ref)[:, None, None]
    qq = q[:, None, None]
    ac = np.empty((v.size, n, n))
    ac[:] = m.base
    ac[:, k:n2, :k] += qq * m.d
    ac[:, k:n2, n2:] = qq * m.c
    ac[:, n2:, :k] = vc * m.b
    ac[:, n2:, n2:] = vc * m.a
    if m.d1 is not None:  # aerodynamic damping q (c_ref / V) D1 xi'
        ac[:, k:n2, k:n2] += (qq / vc) * m.d1
    if m.d2 is not None:  # apparent mass: (I - q (c_ref / V)^2 D2) xi'' = rest of the row block
        ac[:, k:n2, :] = np.linalg.solve(np.eye(k) - (qq / (vc * vc)) * m.d2, ac[:, k:n2, :])
    return ac


def _zoh(m: Model, v: np.ndarray, q: np.ndarray, vectors: bool) -> EigData:
    """Zero-order hold: exact structure at dt = dt* c_ref / V, discrete coupling, s = ln(z) / dt."""
    k, na = m.k, m.na
    n2 = 2 * k
    nv = v.size
    dt = m.dt_star * m.c_ref / v
    aug = np.zeros((nv, n2 + k, n2 + k))
    aug[:, :k, k:n2] = np.eye(k)
    aug[:, k:n2, :k] = -np.diag(m.omega**2)
    aug[:, k:n2, k:n2] = -np.diag(2.0 * m.zeta * m.omega)
    aug[:, k:n2, n2:] = np.eye(k)
    aug *= dt[:, None, None]
    e = scipy.linalg.expm(aug)
    phi, gam = e[:, :n2, :n2], e[:, :n2, n2:]
    qq = q[:, None, None]
    ad = np.zeros((nv, n2 + na, n2 + na))
    ad[:, :n2, :n2] = phi
    ad[:, :n2, :k] += qq * (gam @ m.d)
    ad[:, :n2, n2:] = qq * (gam @ m.c)
    ad[:, n2:, :k] = m.b
    ad[:, n2:, n2:] = m.a
    xs = content = None
    if vectors:
        z, vec = np.linalg.eig(ad)
        xs, content = _full_vectors(vec, m.omega)
    else:
        z = np.linalg.eigvals(ad)
    z = z.astype(complex)
    small = np.abs(z) < 1e-10
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = np.log(np.where(small, 1.0, z)) / dt[:, None]
    lam[small] = np.nan
    if content is not None:
        content[small] = 0.0
    return EigData(lam, xs, content, 2.0 * np.pi / dt)


def lag_mask(m: Model, lam: np.ndarray, v: np.ndarray, content: np.ndarray) -> np.ndarray:
    """Lag roots among eigenvalues lam [n, nt] at speeds v [n]: low structural content near an aero pole."""
    out = content < CONTENT_MIN
    if not out.any() or m.poles.size == 0:
        return out
    rows, cols = np.nonzero(out)
    sv = lam[rows, cols] / (v[rows] / m.c_ref)  # s in t*
    with np.errstate(all="ignore"):
        d = np.min(np.abs(sv[:, None] - m.poles[None, :]) / np.abs(m.poles[None, :]), axis=1)
    out[rows, cols] = d < LAG_NEAR
    return out


def eig_batch(m: Model, v: np.ndarray, q: np.ndarray, vectors: bool = True) -> EigData:
    """Eigen-data of the coupled system at speeds v [n] (m/s) and dynamic pressures q [n] (Pa)."""
    if m.coupling != "tustin":
        e = _zoh(m, v, q, vectors)
    elif not vectors:
        lam = np.linalg.eigvals(_tustin_matrices(m, v, q)).astype(complex)
        return EigData(lam, None, None, np.full(v.size, np.inf))
    else:
        e = _tustin(m, v, q)
    if e.content is not None and e.lag is None:
        e.lag = lag_mask(m, e.lam, v, e.content)
    return e


def _tustin(m: Model, v: np.ndarray, q: np.ndarray) -> EigData:
    """Tustin eigen-data with vectors: null vectors of T(s) on the fast path, else LAPACK eigenvectors."""
    ac = _tustin_matrices(m, v, q)
    per = np.full(v.size, np.inf)
    if m.lam_a is not None:
        lam = np.linalg.eigvals(ac).astype(complex)
        sv = struct_vectors(m, lam, v, q)
        if sv is not None:
            return EigData(lam, sv[0], sv[1], per, sv[2])
    lam, vec = np.linalg.eig(ac)
    xs, content = _full_vectors(vec, m.omega)
    return EigData(lam.astype(complex), xs, content, per)


@dataclass
class EigRequest:
    """A search's request for the eigen-data of ``model`` at speeds v [n] (m/s), dynamic pressures q [n] (Pa)."""

    model: Model
    v: np.ndarray
    q: np.ndarray
    vectors: bool = True
