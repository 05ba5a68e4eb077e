"""Compiled corrector of one continuation step (``continuation.ContinuationTracker._newton_point``, diagonal path).

On the Tustin fast path (aero matrix diagonalized: poles ``lam_a``, residues ``res``) one numba call does the whole
step that the Python path spreads over a ``newton.RootsRequest`` and a dozen small numpy operations:

- the predictor: the Lagrange extrapolation of each branch through the last one to three path points;
- the corrector: Newton on det T(s) for each of the k branches, T(s) = s^2 I + s G + K - q H(s) with
  H(s) = D + sum_i res_i / (s / vc - lam_i) (+ the D1, D2 terms of a continuous model), step
  s <- s - 1 / tr(T^-1 dT/ds), converged when the step is below 1e-7 of the branch scale (``newton.newton_roots``);
- the structural vectors, structural content and lag flags of the roots (``eigen.null_vectors``: one inverse of T
  applied to the fixed generic vector, participations of the structural and aero parts of dT/ds);
- the acceptance tests of the step, in the order of the Python path: predictor error, two branches on one root,
  a lag root, MAC with the previous vector, a structural-content jump, veering with a lag root (``FULL``), the
  damping-hump test (``HUMP``).

The numbers are those of the numpy path up to rounding (a k x k LU with partial pivoting here, LAPACK there);
``tests/test_flutter_newton_kernel.py`` compares the two step by step. numpy's error model: a division by zero
gives inf or NaN, as in numpy.
"""

from __future__ import annotations

import math
from typing import Any

import numba as nb
import numpy as np

from .assignment import content_jump, may_cross

ENABLED = True  # the flutter code uses these kernels on diagonalized models (False: the numpy code they replace, the
# reference of the tests)
ACCEPTED, AMBIGUOUS, HUMP, FULL = 0, 1, 2, 3  # status of a step (continuation: None, HUMP, FULL)


@nb.njit(cache=True, error_model="numpy")
def _lu(a: np.ndarray, perturb: bool) -> tuple[np.ndarray, np.ndarray, bool]:
    """LU factors (in place of a copy) and row pivots of a complex k x k matrix; True when a pivot is exactly 0.

    ``perturb``: an exactly zero pivot becomes 1e-16 of the largest entry instead (inverse iteration at an
    eigenvalue, where T(s) is singular to rounding and LAPACK's pivot would be as small but not 0).
    """
    k = a.shape[0]
    lu = a.copy()
    piv = np.arange(k)
    for c in range(k):
        p = c
        best = abs(lu[c, c])
        for r in range(c + 1, k):
            if abs(lu[r, c]) > best:
                best = abs(lu[r, c])
                p = r
        if best == 0.0:
            big = 0.0
            if perturb:
                for i in range(k):
                    for j in range(k):
                        big = max(big, abs(a[i, j]))
            if big == 0.0:
                return lu, piv, True
            lu[c, c] = 1e-16 * big
        if p != c:
            for j in range(k):
                lu[c, j], lu[p, j] = lu[p, j], lu[c, j]
            piv[c], piv[p] = piv[p], piv[c]
        for r in range(c + 1, k):
            f = lu[r, c] / lu[c, c]
            lu[r, c] = f
            for j in range(c + 1, k):
                lu[r, j] -= f * lu[c, j]
    return lu, piv, False


@nb.njit(cache=True, error_model="numpy")
def _lu_solve(lu: np.ndarray, piv: np.ndarray, b: np.ndarray) -> np.ndarray:
    """X with A X = B from ``_lu``'s factors of A; B [k, n]."""
    k, n = b.shape
    x = np.empty((k, n), np.complex128)
    for i in range(k):
        for j in range(n):
            x[i, j] = b[piv[i], j]
    for j in range(n):
        for i in range(k):
            acc = x[i, j]
            for r in range(i):
                acc -= lu[i, r] * x[r, j]
            x[i, j] = acc
        for i in range(k - 1, -1, -1):
            acc = x[i, j]
            for r in range(i + 1, k):
                acc -= lu[i, r] * x[r, j]
            x[i, j] = acc / lu[i, i]
    return x


@nb.njit(cache=True, error_model="numpy")
def _terms(s: complex, vc: float, q: float, lam_a: np.ndarray, res: np.ndarray, near_r: np.ndarray, d: np.ndarray,
           d1: np.ndarray, d2: np.ndarray, rate: bool, g: np.ndarray,
           kd: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool, bool]:
    """T(s), the aero states' part of dT/ds, the D1, D2 part of dT/ds [k, k], on an aero pole, near an aero pole
    (``newton._terms``, ``eigen.resolvent_diag``)."""
    k = g.size
    ss = s / vc
    on_pole = False
    near = False
    for i in range(lam_a.size):
        den = ss - lam_a[i]
        if den == 0:
            on_pole = True
        else:
            ri = 1.0 / den
            if not (math.isfinite(ri.real) and math.isfinite(ri.imag)):
                on_pole = True
            elif abs(ri) > near_r[i]:
                near = True
    h1 = np.zeros(k * k, np.complex128)
    h2 = np.zeros(k * k, np.complex128)
    if on_pole:  # both aero terms 0 on a pole (``eigen.resolvent_diag``)
        near = True
    else:
        for i in range(lam_a.size):
            ri = 1.0 / (ss - lam_a[i])
            r2 = ri * ri
            for j in range(k * k):
                h1[j] += ri * res[i, j]
                h2[j] += r2 * res[i, j]
    t = np.empty((k, k), np.complex128)
    dta = np.empty((k, k), np.complex128)
    drate = np.zeros((k, k), np.complex128)
    qv = q / vc
    for a in range(k):
        for b in range(k):
            j = a * k + b
            t[a, b] = -q * d[j] - q * h1[j]
            dta[a, b] = qv * h2[j]
            if rate:
                t[a, b] += -q * (ss * d1[j] + ss * ss * d2[j])
                drate[a, b] = -qv * (d1[j] + 2.0 * ss * d2[j])
        t[a, a] += s * s + g[a] * s + kd[a]
    return t, dta, drate, on_pole, near


@nb.njit(cache=True, error_model="numpy")
def _root(s0: complex, scale: float, vc: float, q: float, lam_a: np.ndarray, res: np.ndarray, near_r: np.ndarray,
          d: np.ndarray, d1: np.ndarray, d2: np.ndarray, rate: bool, g: np.ndarray, kd: np.ndarray,
          maxit: int) -> tuple[complex, bool]:
    """Newton root of det T(s) from s0 (rad/s) and whether it converged (``newton.roots_and_vectors``)."""
    s = s0
    k = g.size
    for _ in range(maxit):
        t, dt, drate, _, _ = _terms(s, vc, q, lam_a, res, near_r, d, d1, d2, rate, g, kd)
        for a in range(k):
            dt[a, a] += 2.0 * s + g[a]
        if rate:
            dt += drate
        lu, piv, sing = _lu(t, False)
        if sing:
            return s, True
        x = _lu_solve(lu, piv, dt)
        tr = 0j
        for i in range(k):
            tr += x[i, i]
        if not (math.isfinite(tr.real) and math.isfinite(tr.imag)) or tr == 0:
            return s, False
        step = 1.0 / tr
        s -= step
        if abs(step) <= 1e-7 * scale:
            return s, True
    return s, False


@nb.njit(cache=True, error_model="numpy")
def _vector(s: complex, vc: float, q: float, lam_a: np.ndarray, res: np.ndarray, near_r: np.ndarray, d: np.ndarray,
            d1: np.ndarray, d2: np.ndarray, rate: bool, g: np.ndarray, kd: np.ndarray, omega: np.ndarray,
            rhs: np.ndarray, content_min: float) -> tuple[np.ndarray, float, bool, bool]:
    """Normalized structural vector [xi; s xi / omega] [2k], content, lag flag and whether they are finite at the
    root s (``newton._vectors``, ``eigen.null_vectors``)."""
    k = g.size
    t, dta, drate, on_pole, near = _terms(s, vc, q, lam_a, res, near_r, d, d1, d2, rate, g, kd)
    x = np.zeros(2 * k, np.complex128)
    if on_pole:
        return x, 0.0, near, True
    lu, piv, sing = _lu(t, True)
    if sing:
        return x, np.nan, False, False
    eye = np.zeros((k, k), np.complex128)
    for i in range(k):
        eye[i, i] = 1.0
    ti = _lu_solve(lu, piv, eye)
    y = np.zeros(k, np.complex128)
    zc = np.zeros(k, np.complex128)
    for i in range(k):
        for j in range(k):
            y[i] += ti[i, j] * rhs[j]
            zc[j] += np.conj(rhs[i]) * ti[i, j]
    nrm = 0.0
    for i in range(k):
        x[i] = y[i]
        x[k + i] = (s / omega[i]) * y[i]
        nrm += abs(x[i]) ** 2 + abs(x[k + i]) ** 2
    nrm = math.sqrt(nrm)
    for i in range(2 * k):
        x[i] /= nrm
    ps = 0j
    pa = 0j
    for i in range(k):
        dts = (2.0 * s + g[i]) * y[i]  # structural part of dT/ds applied to xi (D1, D2: structural too)
        da = 0j
        for j in range(k):
            da += dta[i, j] * y[j]
            if rate:
                dts += drate[i, j] * y[j]
        ps += zc[i] * dts
        pa += zc[i] * da
    cont = abs(ps) / (abs(ps) + abs(pa))
    good = math.isfinite(cont)
    for i in range(2 * k):
        good = good and math.isfinite(x[i].real) and math.isfinite(x[i].imag)
    return x, cont, near and cont < content_min, good


@nb.njit(cache=True, error_model="numpy")
def newton_point(xh: np.ndarray, lamh: np.ndarray, x1: float, vc: float, q: float, prev_vec: np.ndarray,
                 prev_content: np.ndarray, has_content: bool, lam_a: np.ndarray, res: np.ndarray, near_r: np.ndarray,
                 d: np.ndarray, d1: np.ndarray, d2: np.ndarray, rate: bool, g: np.ndarray, kd: np.ndarray,
                 omega: np.ndarray, rhs: np.ndarray, careful: bool, hump_ok: bool,
                 consts: np.ndarray) -> tuple[int, np.ndarray, np.ndarray, np.ndarray, float]:
    """(status, roots [k], vectors [2k, k], content [k], predictor error) of the continuation step to x1.

    ``xh`` [n] and ``lamh`` [n, k]: the last n <= 3 path points (coordinates, branch eigenvalues); the previous
    state's vectors and content (``has_content`` False: none yet); ``careful``: before the first unstable point;
    ``hump_ok``: the hump test may shrink the step. ``consts`` = (pred_tol, SAME_ROOT, MAC_STEP, CONTENT_JUMP,
    CONTENT_AWAY, VEER_DROP, CONTENT_MIN, G_UNSTABLE, HUMP_ERR, HUMP_FLOOR). Status ``ACCEPTED``, ``AMBIGUOUS``,
    ``HUMP`` or ``FULL`` (module docstring).
    """
    pred_tol, same_root, mac_step, jump_tol, away_f, veer_drop, content_min = (
        consts[0], consts[1], consts[2], consts[3], consts[4], consts[5], consts[6])
    n, k = lamh.shape
    prev = lamh[n - 1]
    lam = np.zeros(k, np.complex128)
    vec = np.zeros((2 * k, k), np.complex128)
    content = np.zeros(k)
    scale = np.empty(k)
    for j in range(k):
        scale[j] = max(abs(prev[j]), omega[j])
    pred = prev.copy()
    if n > 1:
        pred[:] = 0.0
        for i in range(n):
            w = 1.0
            for m in range(n):
                if m != i:
                    w *= (x1 - xh[m]) / (xh[i] - xh[m])
            for j in range(k):
                pred[j] += w * lamh[i, j]
    lags = False
    for j in range(k):
        s, ok = _root(pred[j], scale[j], vc, q, lam_a, res, near_r, d, d1, d2, rate, g, kd, 30)
        if not ok:
            return AMBIGUOUS, lam, vec, content, np.inf
        x, cont, lag, good = _vector(s, vc, q, lam_a, res, near_r, d, d1, d2, rate, g, kd, omega, rhs, content_min)
        if not good:
            return AMBIGUOUS, lam, vec, content, np.inf
        lam[j] = s
        vec[:, j] = x
        content[j] = cont
        lags = lags or lag
    err = 0.0
    for j in range(k):
        err = max(err, abs(lam[j] - pred[j]) / scale[j])
    if err > pred_tol:
        return AMBIGUOUS, lam, vec, content, err
    for i in range(k):
        for j in range(k):
            if i != j:
                dij = min(abs(lam[i] - lam[j]), abs(lam[i] - np.conj(lam[j])))
                if dij / scale[i] < same_root:
                    return AMBIGUOUS, lam, vec, content, err
    if lags:
        return AMBIGUOUS, lam, vec, content, err
    for j in range(k):
        mac = 0j
        for i in range(2 * k):
            mac += np.conj(prev_vec[i, j]) * vec[i, j]
        if abs(mac) ** 2 < mac_step:
            return AMBIGUOUS, lam, vec, content, err
    if has_content:
        if content_jump(prev, lam, prev_content, content, omega, away_f, jump_tol):
            return AMBIGUOUS, lam, vec, content, err
        if careful:
            for j in range(k):
                away = abs(prev[j]) > away_f * omega[j] and abs(lam[j]) > away_f * omega[j]
                if away and content[j] < 0.5 and prev_content[j] - content[j] > veer_drop:
                    return FULL, lam, vec, content, err
    if careful and hump_ok:
        g0 = np.empty(k)
        g1 = np.empty(k)
        g2 = np.empty(k)
        for j in range(k):
            g0[j] = 2.0 * lamh[n - 2, j].real / abs(lamh[n - 2, j])
            g1[j] = 2.0 * prev[j].real / abs(prev[j])
            g2[j] = 2.0 * lam[j].real / abs(lam[j])
        if may_cross(xh[n - 2], xh[n - 1], x1, g0, g1, g2, consts[7:]):
            return HUMP, lam, vec, content, err
    return ACCEPTED, lam, vec, content, err


NEED_EIG, DONE, OUT_OF_ROOM = 0, 1, 2  # how ``segment`` ends: full eigen-solve at p1, all targets reached, buffer full
CONSTANT_SPEED, CONSTANT_DENSITY = 0, 1  # the sweeps whose p -> (V, q) the kernel evaluates (x = p for both)


@nb.njit(cache=True, error_model="numpy")
def _cond(p: float, kind: int, sw: float, c_ref: float) -> tuple[float, float]:
    """(V / c_ref [1/s], q [Pa]) at p, computed as ``sweeps.ConstantSpeed`` (sw = V0) / ``ConstantDensity``
    (sw = rho_ref) do."""
    if kind == CONSTANT_SPEED:
        rho = 2.0 * p / sw**2
        return sw / c_ref, 0.5 * rho * sw**2
    return p / c_ref, 0.5 * sw * p**2


@nb.njit(cache=True, error_model="numpy")
def segment(todo: np.ndarray, it: int, h: float, fails: int, p_last: float, xh: np.ndarray, lamh: np.ndarray,
            n_hist: int, prev_vec: np.ndarray, prev_content: np.ndarray, has_content: bool, path_len: int,
            careful: bool, lam_a: np.ndarray, res: np.ndarray, near_r: np.ndarray, d: np.ndarray, d1: np.ndarray,
            d2: np.ndarray, rate: bool, g: np.ndarray, kd: np.ndarray, omega: np.ndarray, rhs: np.ndarray,
            kind: int, sw: float, c_ref: float, min_step: float, h_min: float, fallbacks: int, consts: np.ndarray,
            room: int) -> tuple[int, int, float, int, float, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                np.ndarray, int]:
    """Newton steps of ``ContinuationTracker._continue_to`` over the targets todo[it:] (p ascending) until a step
    needs the full spectrum, every target is reached or ``room`` points are taken.

    The path's tail: last p, the last ``n_hist`` <= 3 coordinates ``xh`` [3] and branch eigenvalues ``lamh``
    [3, k] (oldest first), the last state's vectors and content, the path length and whether the first unstable
    point is still ahead (``careful``). ``h``: the step length; ``fails``: full-spectrum steps in a row toward the
    current target; ``h_min`` = H_MIN of the natural range; ``consts`` = (PRED_TOL, PRED_TOL_POST, GROW, SAME_ROOT,
    MAC_STEP, CONTENT_JUMP, CONTENT_AWAY, VEER_DROP, CONTENT_MIN, G_UNSTABLE, HUMP_ERR, HUMP_FLOOR, k_gate): an
    unstable branch marks the first unstable point only at a reduced frequency <= k_gate (``Tracker.unstable``).

    Returns (how it ended, the current target index, h, fails, p1 of the step the full spectrum must take, the
    accepted points' p [n], roots [n, k], vectors [n, 2k, k], contents [n, k], the target index each point
    completes (-1: none) [n], index of the first unstable point among them (-1: none)).
    """
    k = g.size
    pp = np.empty(room)
    lam_o = np.empty((room, k), np.complex128)
    vec_o = np.empty((room, 2 * k, k), np.complex128)
    cont_o = np.empty((room, k))
    tgt = np.full(room, -1, np.int64)
    step_c = np.empty(10)
    step_c[1:] = consts[3:12]
    xh = xh.copy()
    lamh = lamh.copy()
    n = 0
    first = -1
    g_unstable = consts[9]
    k_gate = consts[12]
    while it < todo.size:
        p_t = todo[it]
        while p_last < p_t:
            if n == room:
                return OUT_OF_ROOM, it, h, fails, 0.0, pp[:n], lam_o[:n], vec_o[:n], cont_o[:n], tgt[:n], first
            p0 = p_last
            p1 = p_t if p0 + 1.25 * h >= p_t else p0 + h
            vc, q = _cond(p1, kind, sw, c_ref)
            step_c[0] = consts[0] if careful else consts[1]
            hump_ok = path_len >= 3 and p1 - p0 > min_step
            status, lam, vec, cont, err = newton_point(
                xh[3 - n_hist:], lamh[3 - n_hist:], p1, vc, q, prev_vec, prev_content, has_content, lam_a, res,
                near_r, d, d1, d2, rate, g, kd, omega, rhs, careful, hump_ok, step_c)
            if status == ACCEPTED:
                pp[n] = p1
                lam_o[n] = lam
                vec_o[n] = vec
                cont_o[n] = cont
                for i in range(2):
                    xh[i] = xh[i + 1]
                    lamh[i] = lamh[i + 1]
                xh[2] = p1
                lamh[2] = lam
                n_hist = min(n_hist + 1, 3)
                prev_vec = vec
                prev_content = cont
                has_content = True
                path_len += 1
                p_last = p1
                if careful:
                    for j in range(k):
                        if 2.0 * lam[j].real / abs(lam[j]) > g_unstable and abs(lam[j].imag) * 0.5 <= k_gate * vc:
                            careful = False
                    if not careful:
                        first = n
                n += 1
                fails = 0
                tol = consts[0] if careful else consts[1]
                h = max(h, p1 - p0) * (2.0 if err < tol / consts[2] else 1.0)
                continue
            if status != FULL and (p1 - p0 > h_min or status == HUMP):
                h = 0.25 * (p1 - p0)
                continue
            fails += 1
            if fails >= fallbacks:
                p1 = p_t
            return NEED_EIG, it, h, fails, p1, pp[:n], lam_o[:n], vec_o[:n], cont_o[:n], tgt[:n], first
        if n > 0:
            tgt[n - 1] = it
        it += 1
        fails = 0
    return DONE, it, h, fails, 0.0, pp[:n], lam_o[:n], vec_o[:n], cont_o[:n], tgt[:n], first


@nb.njit(cache=True, error_model="numpy")
def roots_vectors(s0: np.ndarray, scale: np.ndarray, vc: np.ndarray, q: np.ndarray, want: np.ndarray,
                  lam_a: np.ndarray, res: np.ndarray, near_r: np.ndarray, d: np.ndarray, d1: np.ndarray,
                  d2: np.ndarray, rate: bool, g: np.ndarray, kd: np.ndarray, omega: np.ndarray, rhs: np.ndarray,
                  content_min: float, maxit: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                                           np.ndarray, np.ndarray]:
    """``newton.roots_and_vectors`` of M requests of one model: roots [M], found [M], and where ``want`` [M] asks
    for them (and the root was found) the structural vectors [M, 2k], content [M], lag flag [M], finite [M]."""
    m = s0.size
    k = g.size
    roots = np.empty(m, np.complex128)
    found = np.zeros(m, np.bool_)
    xs = np.zeros((m, 2 * k), np.complex128)
    cont = np.zeros(m)
    lag = np.zeros(m, np.bool_)
    good = np.zeros(m, np.bool_)
    for i in range(m):
        roots[i], found[i] = _root(s0[i], scale[i], vc[i], q[i], lam_a, res, near_r, d, d1, d2, rate, g, kd, maxit)
        if found[i] and want[i]:
            xs[i], cont[i], lag[i], good[i] = _vector(roots[i], vc[i], q[i], lam_a, res, near_r, d, d1, d2, rate, g,
                                                      kd, omega, rhs, content_min)
    return roots, found, xs, cont, lag, good


@nb.njit(cache=True, error_model="numpy")
def vectors(ss: np.ndarray, vc: np.ndarray, q: np.ndarray, lam_a: np.ndarray, res: np.ndarray, near_r: np.ndarray,
            d: np.ndarray, d1: np.ndarray, d2: np.ndarray, rate: bool, g: np.ndarray, kd: np.ndarray,
            omega: np.ndarray, rhs: np.ndarray,
            content_min: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
    """``eigen.struct_vectors``' structural vectors [M, 2k], content [M] and lag flags [M] of eigenvalues ss [M]
    (rad/s) at V / c_ref = vc [M], q [M], and whether all are finite."""
    m = ss.size
    k = g.size
    xs = np.zeros((m, 2 * k), np.complex128)
    cont = np.zeros(m)
    lag = np.zeros(m, np.bool_)
    ok = True
    for i in range(m):
        x, c, lg, good = _vector(ss[i], vc[i], q[i], lam_a, res, near_r, d, d1, d2, rate, g, kd, omega, rhs,
                                 content_min)
        xs[i] = x
        cont[i] = c
        lag[i] = lg
        ok = ok and good
    return xs, cont, lag, ok


def merged_poles(lam_a: np.ndarray, res: np.ndarray,
                 near_r: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Distinct aero poles, the summed residues of each and their near-pole radii: the same H(s) with fewer terms
    (a rational-function ROM repeats every lag pole once per basis shape; only exactly equal poles are merged)."""
    uniq, first, inv = np.unique(lam_a, return_index=True, return_inverse=True)
    out = np.zeros((uniq.size, res.shape[1]), complex)
    np.add.at(out, inv.ravel(), res)
    return np.ascontiguousarray(uniq, complex), out, np.ascontiguousarray(near_r[first], float)


ModelArgs = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, bool, np.ndarray, np.ndarray,
                  np.ndarray, np.ndarray]


def model_args(m: Any) -> ModelArgs:
    """The arrays of a diagonalized Tustin ``flutter.model.Model`` in the kernels' argument order (lam_a ... rhs),
    built once per model."""
    if m.kernel is None:
        assert m.lam_a is not None and m.res is not None
        zero = np.zeros(m.k * m.k)
        rate = m.d1 is not None or m.d2 is not None
        d1 = zero if m.d1 is None else np.ascontiguousarray(m.d1, float).ravel()
        d2 = zero if m.d2 is None else np.ascontiguousarray(m.d2, float).ravel()
        lam_a, res, near_r = merged_poles(m.lam_a, m.res, m.near_r)
        from .eigen import _rhs  # eigen imports this module

        rhs = _rhs(m.k)[:, 0]
        m.kernel = (lam_a, res, near_r, np.ascontiguousarray(m.d, float).ravel(), d1, d2, rate,
                    np.ascontiguousarray(2.0 * m.zeta * m.omega, float), np.ascontiguousarray(m.omega**2, float),
                    np.ascontiguousarray(m.omega, float), np.ascontiguousarray(rhs, complex))
    return m.kernel


def warm_up() -> None:
    """Compile every kernel of the tracker (``assignment.warm_up`` and these) for the layouts the tracker passes, or
    load them from numba's cache: a worker calls it before its first evaluation, ``make install`` and the image build
    fill the cache."""
    from .assignment import warm_up as warm_up_assignment

    warm_up_assignment()
    k = 2
    lam_a = np.array([-1.0 + 0.0j, -2.0 + 1.0j, -2.0 - 1.0j])
    res = np.full((3, k * k), 0.1 + 0.0j)
    omega = np.array([10.0, 30.0])
    args = (lam_a, res, 4.0 / np.abs(lam_a), np.zeros(k * k), np.zeros(k * k), np.zeros(k * k), False,
            0.02 * omega, omega**2, omega, np.array([1.0 + 0.0j, 0.5 + 0.5j]))
    lam = np.array([-0.1 + 10.0j, -0.3 + 30.0j])
    vec = np.ascontiguousarray(np.vstack([np.eye(k), np.eye(k)]) + 0j)
    consts = np.array([0.05, 0.3, 8.0, 1e-6, 0.9, 0.1, 0.5, 0.002, 0.1, 1e-9, 0.5, 1e-6, np.inf])
    segment(np.array([1.0, 2.0]), 0, 0.5, 0, 0.0, np.array([0.0, 0.0, 0.0]), np.vstack([lam, lam, lam]), 1, vec,
            np.ones(k), True, 1, True, *args, CONSTANT_SPEED, 100.0, 1.0, 1e-4, 1e-3, 4, consts, 256)
    newton_point(np.array([0.0]), lam[None, :].copy(), 1.0, 100.0, 1.0, vec, np.ones(k), True, *args, True, False,
                 np.concatenate([consts[:1], consts[3:12]]))
    roots_vectors(lam.copy(), omega.copy(), np.full(k, 100.0), np.ones(k), np.ones(k, np.bool_), *args, 0.1, 30)
    vectors(lam.copy(), np.full(k, 100.0), np.ones(k), *args, 0.1)
