"""Compiled kernel of one tracking step (``tracking.assign``): the assignment costs of the candidates of one sweep
point to the k branches, their optimal assignment, and the step's diagnostics, in one numba call.

The tracker calls the step about 230 times per structure (5 Machs); in numpy each call is some 30 small array
operations plus ``scipy.optimize.linear_sum_assignment``, whose call overhead (about 80 us) is most of the
tracking time. The kernel computes the same numbers in the same order of operations:

- the cost of ``tracking.assign`` (MAC, relative distance, lag penalty, content term with its per-row shift, a
  non-finite cost set to 1e6; a NaN content makes its row's shift NaN, as numpy's row minimum does);
- the rectangular linear assignment (k rows <= n columns) by the shortest augmenting path method of Jonker and
  Volgenant in the form of Crouse (IEEE TAES 52(4), 2016), with ties between equal path costs broken toward an
  unassigned column, as in scipy's implementation of the same method, so both give the same assignment;
- the smallest assigned MAC, the largest relative jump and the near-tie gap (``tracking._tie_gap``).

``tests/test_flutter_assignment.py`` checks the kernel against the numpy/scipy step on random and real steps.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np


@nb.njit(cache=True)
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


@nb.njit(cache=True)
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


@nb.njit(cache=True)
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
