"""Continuation of the k structural branches along the sweep parameter p."""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from .eigen import EigData, eig_batch
from .model import Model
from .sweeps import Sweep


@dataclass
class Branches:
    """Tracked state of the k structural branches."""

    lam: np.ndarray  # [k] complex s
    vec: np.ndarray  # [2k, k] normalized structural vectors [xi; xi'/omega] (columns)


def initial_branches(omega: np.ndarray, zeta: np.ndarray) -> Branches:
    """In-vacuo structural poles (q = 0) and their structural eigenvectors."""
    k = omega.size
    lam = omega * (-zeta + 1j * np.sqrt(np.maximum(1.0 - zeta**2, 0.0)))
    a = np.concatenate([np.eye(k), np.diag(lam / omega)], axis=0).astype(complex)
    return Branches(lam, a / np.linalg.norm(a, axis=0))


def assign(
    prev: Branches, lam_c: np.ndarray, a_c: np.ndarray, period: float, weight: float, omega: np.ndarray
) -> tuple[Branches, float, float, float]:
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
    return Branches(new_lam, a_c[:, cols]), float(mac[idx, cols].min()), float(dist[idx, cols].max()), gap


class Tracker:
    """Continuation of the structural branches along a sweep."""

    def __init__(self, model: Model, sweep: Sweep, weight: float):
        self.m = model
        self.sweep = sweep
        self.weight = weight

    def start(self) -> Branches:
        """The branch state at p_start (q = 0): the in-vacuo poles."""
        return initial_branches(self.m.omega, self.m.zeta)

    def eig(self, p: np.ndarray, vectors: bool = True) -> EigData:
        """Eigen-data at the sweep parameters p."""
        v, rho = self.sweep.cond(p)
        return eig_batch(self.m, v, 0.5 * rho * v**2, vectors)

    def step(self, prev: Branches, p0: float, p1: float, e1: EigData, depth: int = 0) -> Branches:
        """Track from p0 (state prev) to p1 (eigen-data e1 of that single point); an ambiguous step is split
        in four sub-steps (one batched eigen-solve of the three interior points), at most twice (1/16)."""
        assert e1.xs is not None
        new, mac_min, jump, gap = assign(prev, e1.lam[0], e1.xs[0], float(e1.period[0]), self.weight, self.m.omega)
        if (mac_min < 0.8 or jump > 1.0 or gap < 0.0) and depth < 2:
            ps = p0 + (p1 - p0) * np.array([0.25, 0.5, 0.75])
            em = self.eig(ps)
            state, pa = prev, p0
            for i in range(3):
                state = self.step(state, pa, ps[i], em.point(i), depth + 1)
                pa = ps[i]
            return self.step(state, pa, p1, e1, depth + 1)
        return new

    def iter_track(self, grid: np.ndarray) -> Iterator[Branches]:
        """Branch states at the grid points in turn, from the in-vacuo poles at p_start."""
        eg = self.eig(grid)
        state = self.start()
        p_prev = self.sweep.p_start
        for i in range(grid.size):
            state = self.step(state, p_prev, float(grid[i]), eg.point(i))
            yield state
            p_prev = float(grid[i])

    def track(self, grid: np.ndarray) -> list[Branches]:
        """Branch states at every grid point."""
        return list(self.iter_track(grid))
