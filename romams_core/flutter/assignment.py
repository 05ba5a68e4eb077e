"""Compiled kernels of one tracking step: ``assign_step`` (``tracking.assign``: the assignment costs of the
candidates of one sweep point to the k branches, their optimal assignment and the step's diagnostics, in one numba
call) and the refinement checks of ``tracking.Tracker._split`` (``content_jump``, ``not_smooth_or_hump``).

The tracker calls the step about 230 times per structure (5 Machs); in numpy each call is some 30 small array
operations plus ``scipy.optimize.linear_sum_assignment``, whose call overhead (about 80 us) is most of the
tracking time. The kernel computes the same numbers in the same order of operations:

- the cost of ``tracking.assign`` (MAC, relative distance, lag penalty, content term with its per-row shift, a
  non-finite cost set to 1e6; a NaN content makes its row's shift NaN, as numpy's row minimum does);
- the rectangular linear assignment (k rows <= n columns) by the shortest augmenting path method of Jonker and
  Volgenant in the form of Crouse (IEEE TAES 52(4), 2016), with ties between equal path costs broken toward an
  unassigned column, as in scipy's implementation of the same method, so both give the same assignment;
- the smallest assigned MAC, the largest relative jump and the near-tie gap (``tracking._tie_gap``).

``tests/test_flutter_assignment.py`` checks the kernels against the numpy/scipy versions on random and real steps.
All use numpy's error model (a division by zero gives inf or NaN, as in numpy, not an exception).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np


@nb.njit(cache=True, error_model="numpy")
def lsap(cost: np.ndarray) -> np.ndarray:
    """Column of each row [nr] minimizing the summed cost [nr, nc] (nr <= nc, finite costs): shortest
    augmenting paths with dual updates (Crouse 2016); -1 for every row if no assignment exists."""
    nr, nc = cost.shape
    u = np.zeros(nr)
    v = np.zeros(nc)
    col4row = np.full(nr, -1, np.int64)
    row4col = np.full(nc, -1, np.int64)
    shortest = np.empty(nc)
    path = np.empty(nc, np.int64)
    remaining = np.empty(nc, np.int64)
    sr = np.zeros(nr, np.bool_)
    sc = np.zeros(nc, np.bool_)
    for cur in range(nr):
        shortest[:] = np.inf
        path[:] = -1
        sr[:] = False
        sc[:] = False
        for it in range(nc):
            remaining[it] = nc - it - 1
        n_rem = nc
        min_val = 0.0
        i = cur
        sink = -1
        while sink == -1:
            index = -1
            lowest = np.inf
            sr[i] = True
            for it in range(n_rem):
                j = remaining[it]
                r = min_val + cost[i, j] - u[i] - v[j]
                if r < shortest[j]:
                    path[j] = i
                    shortest[j] = r
                if shortest[j] < lowest or (shortest[j] == lowest and row4col[j] == -1):
                    lowest = shortest[j]
                    index = it
            min_val = lowest
            if min_val == np.inf:
                return np.full(nr, -1, np.int64)
            j = remaining[index]
            if row4col[j] == -1:
                sink = j
            else:
                i = row4col[j]
            sc[j] = True
            n_rem -= 1
            remaining[index] = remaining[n_rem]
        u[cur] += min_val
        for i in range(nr):
            if sr[i] and i != cur:
                u[i] += min_val - shortest[col4row[i]]
        for j in range(nc):
            if sc[j]:
                v[j] -= min_val - shortest[j]
        j = sink
        while True:
            i = path[j]
            row4col[j] = i
            nxt = col4row[i]
            col4row[i] = j
            j = nxt
            if i == cur:
                break
    return col4row


@nb.njit(cache=True, error_model="numpy")
def _costs(prev_lam: np.ndarray, prev_vec: np.ndarray, lam_c: np.ndarray, a_c: np.ndarray, period: float,
           omega: np.ndarray, weight: float, lag_c: np.ndarray, content: np.ndarray, has_content: bool,
           consts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(s [k, n] unwrapped candidates, mac [k, n], dist [k, n], cost [k, n]) of ``tracking.assign``;
    ``consts`` = (LAG_PENALTY, W_CONTENT, VEER_DIST, CONTENT_AWAY)."""
    lag_pen, w_content, veer, away_f = consts[0], consts[1], consts[2], consts[3]
    k, n = prev_lam.size, lam_c.size
    s = np.empty((k, n), np.complex128)
    mac = np.empty((k, n))
    dist = np.empty((k, n))
    cost = np.empty((k, n))
    for i in range(k):
        scale = max(abs(prev_lam[i]), omega[i])
        for j in range(n):
            if math.isfinite(period):
                s[i, j] = lam_c[j] + (1j * period) * np.rint((prev_lam[i].imag - lam_c[j].imag) / period)
            else:
                s[i, j] = lam_c[j]
            acc = 0j
            for r in range(a_c.shape[0]):
                acc += prev_vec[r, i].conjugate() * a_c[r, j]
            mac[i, j] = abs(acc) ** 2
            dist[i, j] = abs(s[i, j] - prev_lam[i]) / scale
            cost[i, j] = (1.0 - mac[i, j]) + weight * dist[i, j]
            if lag_c[j]:
                cost[i, j] += lag_pen
    if has_content:
        term = np.empty((k, n))
        all_away = True
        for i in range(k):
            for j in range(n):
                c = content[j]
                low = np.nan if math.isnan(c) else w_content * max(0.5 - c, 0.0)
                term[i, j] = low if dist[i, j] < veer else 0.5 * w_content
                if not (abs(prev_lam[i]) > away_f * omega[i] and abs(s[i, j]) > away_f * omega[i]):
                    all_away = False
        for i in range(k):
            if not all_away:
                for j in range(n):
                    if not (abs(prev_lam[i]) > away_f * omega[i] and abs(s[i, j]) > away_f * omega[i]):
                        term[i, j] = 0.0
            lo = np.inf
            for j in range(n):
                if math.isnan(term[i, j]):
                    lo = np.nan
                    break
                lo = min(lo, term[i, j])
            for j in range(n):
                cost[i, j] += term[i, j] - lo
    for i in range(k):
        for j in range(n):
            if not math.isfinite(cost[i, j]):
                cost[i, j] = 1e6
    return s, mac, dist, cost


@nb.njit(cache=True, error_model="numpy")
def assign_step(prev_lam: np.ndarray, prev_vec: np.ndarray, lam_c: np.ndarray, a_c: np.ndarray, period: float,
                omega: np.ndarray, weight: float, lag_c: np.ndarray, content: np.ndarray, has_content: bool,
                consts: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, float, float, bool]:
    """(cols [k], new_lam [k], mac_min, jump, tie gap, lag assigned) of one step of ``tracking.assign``
    (k <= n candidates); cols all -1 when no assignment exists."""
    s, mac, dist, cost = _costs(prev_lam, prev_vec, lam_c, a_c, period, omega, weight, lag_c, content, has_content,
                                consts)
    k, n = cost.shape
    cols = lsap(cost)
    new_lam = np.empty(k, np.complex128)
    mac_min, jump, gap, lag = np.inf, -np.inf, np.inf, False
    if cols[0] < 0:
        return cols, new_lam, mac_min, jump, gap, lag
    for i in range(k):
        j = cols[i]
        new_lam[i] = s[i, j]
        mac_min = min(mac_min, mac[i, j])
        jump = max(jump, dist[i, j])
        lag = lag or lag_c[j]
        if n > 1:
            m1, m2 = np.inf, np.inf  # the two smallest costs of the row
            for jj in range(n):
                c = cost[i, jj]
                if c < m1:
                    m1, m2 = c, m1
                elif c < m2:
                    m2 = c
            lj, wj = prev_lam[i], omega[i]
            if lj.imag > 0.05 * wj and -lj.real < 0.25 * abs(lj):
                chosen = cost[i, j]
                runner = m2 if chosen == m1 else m1
                gap = min(gap, runner - 1.5 * chosen - 0.002)
    return cols, new_lam, mac_min, jump, gap, lag


@nb.njit(cache=True, error_model="numpy")
def content_jump(prev_lam: np.ndarray, new_lam: np.ndarray, prev_content: np.ndarray, new_content: np.ndarray,
                 omega: np.ndarray, away_f: float, jump_tol: float) -> bool:
    """``tracking._content_jump``: some branch away from s = 0 changes its structural content by more than
    ``jump_tol`` (NaN content: not computed, no jump)."""
    for j in range(prev_lam.size):
        if abs(prev_lam[j]) > away_f * omega[j] and abs(new_lam[j]) > away_f * omega[j]:
            if abs(new_content[j] - prev_content[j]) > jump_tol:
                return True
    return False


@nb.njit(cache=True, error_model="numpy")
def not_smooth_or_hump(sm: np.ndarray, s0: np.ndarray, s1: np.ndarray, xm: float, x0: float, x1: float,
                       omega: np.ndarray, hump: bool, consts: np.ndarray) -> bool:
    """The smoothness and damping-hump checks of ``Tracker._split`` for branch roots sm, s0, s1 [k] at x (xm, x0,
    x1): s1 farther than SMOOTH_TOL (relative) from the linear extrapolation, or (``hump``) ``may_cross`` on their
    dampings g = 2 Re s / |s|; ``consts`` = (SMOOTH_TOL, G_UNSTABLE, HUMP_ERR, HUMP_FLOOR). NaNs as numpy's max: a
    NaN deviation makes the smoothness check pass."""
    smooth_tol = consts[0]
    k = s0.size
    worst = -np.inf
    for j in range(k):
        pred = s0[j] + (s0[j] - sm[j]) * ((x1 - x0) / (x0 - xm))
        r = abs(s1[j] - pred) / max(abs(s0[j]), omega[j])
        if math.isnan(r) or math.isnan(worst):
            worst = np.nan
        else:
            worst = max(worst, r)
    if worst > smooth_tol:
        return True
    if not hump:
        return False
    g0 = np.empty(k)
    g1 = np.empty(k)
    g2 = np.empty(k)
    for j in range(k):
        g0[j] = 2.0 * sm[j].real / abs(sm[j])
        g1[j] = 2.0 * s0[j].real / abs(s0[j])
        g2[j] = 2.0 * s1[j].real / abs(s1[j])
    return may_cross(xm, x0, x1, g0, g1, g2, consts[1:])


@nb.njit(cache=True, error_model="numpy")
def _nanmax(a: float, b: float) -> float:
    """numpy's maximum of two floats (NaN if either is NaN)."""
    return np.nan if math.isnan(a) or math.isnan(b) else max(a, b)


@nb.njit(cache=True, error_model="numpy")
def may_cross(p0: float, p1: float, p2: float, g0: np.ndarray, g1: np.ndarray, g2: np.ndarray,
              consts: np.ndarray) -> bool:
    """``tracking._may_cross`` on the dampings g0, g1, g2 [k] at p0 < p1 < p2; ``consts`` = (G_UNSTABLE, HUMP_ERR,
    HUMP_FLOOR)."""
    g_unstable, hump_err, hump_floor = consts[0], consts[1], consts[2]
    for j in range(g2.size):
        if g2[j] > g_unstable:
            return False  # the crossing is bracketed by the new point itself
    for j in range(g2.size):
        d01 = (g1[j] - g0[j]) / (p1 - p0)
        d12 = (g2[j] - g1[j]) / (p2 - p1)
        err = abs(g2[j] - (g1[j] + d01 * (p2 - p1)))
        c2 = (d12 - d01) / (p2 - p0)  # leading coefficient of the parabola
        pv = 0.5 * (p1 + p2) - 0.5 * d12 / c2  # vertex: derivative d12 + c2 (2 p - p1 - p2) = 0
        gv = g1[j] + (pv - p1) * (d12 + c2 * (pv - p2))
        top = _nanmax(g1[j], g2[j])
        if c2 < 0 and pv > p1 and pv < p2:
            top = _nanmax(top, gv)
        if top + hump_err * err > hump_floor:
            return True
    return False


def warm_up() -> None:
    """Compile every kernel for the tracker's array layouts (or load them from numba's cache): a worker calls it
    before its first evaluation, ``make install`` and the image build fill the cache (the first compilation takes
    10-20 s, a cached load under 1 s)."""
    k, n = 2, 3
    rng = np.random.default_rng(0)
    lam = np.array([-1.0 + 10.0j, -2.0 + 30.0j])
    vec = np.asfortranarray(rng.standard_normal((2 * k, k)) + 0j)
    cand = np.array([-1.0 + 11.0j, -2.0 + 29.0j, -50.0 + 0.0j])
    a_c = np.asfortranarray(rng.standard_normal((2 * k, n)) + 0j)
    omega = np.array([10.0, 30.0])
    consts = np.array([10.0, 2.0, 0.25, 0.5])
    for content, has in ((np.zeros(0), False), (np.array([1.0, 1.0, 0.0]), True)):
        assign_step(lam, vec, cand, a_c, np.inf, omega, 0.5, np.zeros(n, np.bool_), content, has, consts)
    content_jump(lam, lam, np.ones(k), np.ones(k), omega, 0.5, 0.1)
    not_smooth_or_hump(lam, lam, lam, 0.0, 1.0, 2.0, omega, True, np.array([0.3, 1e-9, 0.5, 1e-6]))
