"""Properties of the flutter point: modal shares, SDOFF single-mode check, frequency separation."""

from __future__ import annotations

import math

import numpy as np

from .model import Model
from .sweeps import Sweep
from .tracking import Branches, Solve, Tracker


def modal_shares(state: Branches, branch: int) -> np.ndarray:
    """Modal shares [k] of a branch's structural vector, [xi; xi'/omega] normalization (sum 1)."""
    k = state.lam.size
    vec = state.vec[:, branch]
    share = np.abs(vec[:k]) ** 2 + np.abs(vec[k:]) ** 2
    return share / share.sum()


def frequency_separation(omega_path: np.ndarray, branch: int) -> float:
    """Minimum relative frequency gap between the flutter branch and the other branches over omega_path [n, k]."""
    if omega_path.shape[1] < 2:
        return math.inf
    wb = np.abs(omega_path[:, branch])
    others = np.delete(omega_path, branch, axis=1)
    return float(np.min(np.abs(others - omega_path[:, [branch]]) / np.where(wb > 0, wb, 1.0)[:, None]))


def single_mode_unstable(m: Model, sweep: Sweep, j: int, p_end: float, weight: float, n: int = 6,
                         k_gate: float = math.inf) -> Solve[bool]:
    """True when structural mode j alone (diagonal aero term only) has an unstable oscillatory root at some p <= p_end.

    A zero-frequency (divergence) root of the single mode does not count: SDOFF is a dynamic instability. Nor does
    a root above the band k_gate (``Tracker.unstable``).
    """
    if m.k == 1:
        return True
    sub = m.submodel(j)
    tr = Tracker(sub, sweep, weight, k_gate)
    # fast path: no unstable oscillatory root at all at p_end -> stable (a single-mode hump that returns
    # to stability before p_end would be missed; such a hump is not flutter-critical at q_f anyway)
    lam_end = (yield from tr.eig(np.array([p_end]), vectors=False)).lam[0]
    if not np.any((lam_end.real > 1e-9 * np.abs(lam_end)) & (np.abs(lam_end.imag) > 0.05 * sub.omega[0])):
        return False
    grid = np.linspace(sweep.p_start, p_end, n + 1)[1:]
    eg = yield from tr.eig(grid)
    state, p_prev = tr.start(), sweep.p_start
    for i in range(grid.size):  # the grid points in turn (no pre-crossing refinement)
        state = yield from tr.step(state, p_prev, float(grid[i]), eg.point(i))
        s = state.lam[0]
        oscillatory = abs(s.imag) > 0.05 * sub.omega[0]  # not divergence
        if s.real > 1e-9 * abs(s) and oscillatory and tr.in_band(float(grid[i]), state)[0]:
            return True
        p_prev = float(grid[i])
    return False
