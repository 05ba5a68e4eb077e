"""Continuation of the k structural branches along the sweep parameter p, with adaptive refinement.

Each step assigns the eigenvalues of the next sweep point to the branches (Hungarian assignment, ``assign``).
A step is refined -- split into four sub-steps whose three interior points are solved in one batched
eigen-solve, recursively -- when the assignment is not trustworthy:

- ambiguity: an assigned MAC below ``MAC_MIN``, a relative eigenvalue jump above ``JUMP_MAX``, a near-tie
  (a runner-up candidate nearly as cheap as the assigned one), or a branch continued on a lag root;
- before the first unstable point only (the part of the sweep that decides the flutter point), also a step
  that smooth continuation does not predict -- an eigenvalue farther than ``SMOOTH_TOL`` (relative) from the
  linear extrapolation of the branch's last two points -- and a step where a branch's damping g could reach
  zero between two stable points: the parabola through its last three values, plus the error of the linear
  extrapolation of g as the estimate's uncertainty, rises above zero (``_may_cross``). The first steps from
  q = 0 go through fixed start points (``Sweep.start_points``), the same for every grid.

Before the first unstable point the refinement goes down to a minimum step fixed by the sweep (not by the
number of coarse points), so the flutter point does not depend on the coarse grid; after it, ambiguous steps
are split at most twice (they only shape the post-flutter V-g curves). A candidate that ``eigen.lag_mask``
marks as an aerodynamic lag root (low structural content, next to an aero pole) costs ``LAG_PENALTY`` more,
so it is taken only when no structural candidate is left, and then the result is flagged.
"""

from __future__ import annotations

import math
from collections.abc import Generator
from dataclasses import dataclass, field
from typing import Any, TypeVar

import numpy as np
from scipy.optimize import linear_sum_assignment

from .assignment import assign_step, content_jump, may_cross, not_smooth_or_hump
from .eigen import EigData, EigRequest
from .model import Model
from .newton import Request
from .sweeps import Sweep

MAC_MIN = 0.8  # assigned MAC below this: ambiguous step
JUMP_MAX = 1.0  # assigned |s1 - s0| / max(|s0|, omega_j) above this: ambiguous step
SMOOTH_TOL = 0.3  # |s1 - linear extrapolation| / max(|s0|, omega_j) above this: step not smooth (pre-crossing)
LAG_PENALTY = 10.0  # extra assignment cost of a lag-root candidate
W_CONTENT = 2.0  # assignment cost per unit of structural content a candidate has below 0.5
CONTENT_JUMP = 0.1  # content change of a branch in one step above which the step is refined (pre-crossing)
VEER_DIST = 0.25  # relative distance within which roots compete by structural content
CONTENT_AWAY = 0.5  # content continuity only for roots with |s| > this x omega_j (participation degenerates at 0)
POST_CROSSING_DEPTH = 2  # split levels of an ambiguous step after the first unstable point
MAX_REFINE_POINTS = 400  # refinement budget (eigen-solved points) of one search
G_UNSTABLE = 1e-9  # g above which a branch counts as unstable
HUMP_FLOOR = 1e-6  # a damping hump is resolved when its estimate (+ uncertainty) reaches above this g
HUMP_ERR = 0.5  # uncertainty of the parabola estimate of g, relative to the linear extrapolation error
_NO_CONTENT = np.zeros(0)

T = TypeVar("T")
Solve = Generator[Request, Any, T]  # a computation that yields eigen requests and returns a T (batch.py)


@dataclass
class Branches:
    """Tracked state of the k structural branches."""

    lam: np.ndarray  # [k] complex s
    vec: np.ndarray  # [2k, k] normalized structural vectors [xi; xi'/omega] (columns)
    lag: bool = False  # some branch was continued on a lag-root candidate (no structural one left)
    content: np.ndarray | None = None  # [k] structural content of the branch roots (None: 1, the in-vacuo poles)


@dataclass
class StepCheck:
    """Diagnostics of one assignment step."""

    mac_min: float  # smallest assigned MAC
    jump: float  # largest relative eigenvalue change
    gap: float  # smallest margin of a runner-up over 1.5 x the assigned cost (< 0: near-tie)
    lag: bool  # a lag-root candidate was assigned

    @property
    def ambiguous(self) -> bool:
        return self.mac_min < MAC_MIN or self.jump > JUMP_MAX or self.gap < 0.0 or self.lag


def initial_branches(omega: np.ndarray, zeta: np.ndarray) -> Branches:
    """In-vacuo structural poles (q = 0) and their structural eigenvectors."""
    k = omega.size
    lam = omega * (-zeta + 1j * np.sqrt(np.maximum(1.0 - zeta**2, 0.0)))
    a = np.concatenate([np.eye(k), np.diag(lam / omega)], axis=0).astype(complex)
    return Branches(lam, a / np.linalg.norm(a, axis=0))


def _tie_gap(cost: np.ndarray, chosen: list[float], prev: Branches, omega: np.ndarray) -> float:
    """Smallest margin of a runner-up over 1.5 x the assigned cost (+0.002) of the lightly damped branches.

    A smaller step, where the true continuation's cost tends to 0, separates a near-tie (e.g. an aero pole
    beside a mode). Heavily damped pairs splitting into two real roots are genuine, harmless ties and are not
    checked. Runner-up of a row: its second-smallest cost when the assigned one is the smallest, else its
    smallest.
    """
    gap = math.inf
    if cost.shape[1] > 1:
        two = np.partition(cost, 1, axis=1)[:, :2].tolist()
        for j, (lj, wj) in enumerate(zip(prev.lam.tolist(), omega.tolist(), strict=True)):
            if lj.imag > 0.05 * wj and -lj.real < 0.25 * abs(lj):
                runner = two[j][1] if chosen[j] == two[j][0] else two[j][0]
                gap = min(gap, runner - 1.5 * chosen[j] - 0.002)
    return gap


def assign(prev: Branches, e: EigData, weight: float, omega: np.ndarray) -> tuple[Branches, StepCheck]:
    """One tracking step: Hungarian assignment of the candidates of one sweep point ``e`` to the branches.

    Cost: (1 - MAC of the normalized structural vectors) + weight x eigenvalue distance relative to
    max(|s_prev|, omega_j) (a branch heading for s = 0 keeps a finite scale) + W_CONTENT x (0.5 - structural
    content)+ of the candidate (content counted 0 beyond VEER_DIST, and the term left out near s = 0) +
    LAG_PENALTY for a lag-root candidate (``eigen.lag_mask``). ZOH eigenvalues are unwrapped by the alias period.
    Computed by the compiled kernel ``assignment.assign_step``; ``assign_numpy`` is the same step in numpy and
    scipy (its reference in the tests).
    """
    assert e.xs is not None
    lam_c, a_c, period = e.lam[0], e.xs[0], float(e.period[0])
    k = prev.lam.size
    if lam_c.size < k:
        return assign_numpy(prev, e, weight, omega)
    lag_c = np.zeros(lam_c.size, bool) if e.lag is None else e.lag[0]
    content = _NO_CONTENT if e.content is None else e.content[0]
    c = np.ascontiguousarray  # one compiled signature: 1-D arrays contiguous, the vectors in Fortran order (no copy
    f = np.asfortranarray  # for the solver's own layouts)
    cols, new_lam, mac_min, jump, gap, lag = assign_step(
        c(prev.lam), f(prev.vec), c(lam_c), f(a_c), period, c(omega, dtype=float), float(weight), c(lag_c),
        c(content, dtype=float), e.content is not None,
        np.array([LAG_PENALTY, W_CONTENT, VEER_DIST, CONTENT_AWAY]))  # read at each call (tests vary them)
    if cols[0] < 0:  # no finite assignment (cannot happen with the finite costs): the reference path decides
        return assign_numpy(prev, e, weight, omega)
    check = StepCheck(float(mac_min), float(jump), float(gap), bool(lag))
    new_content = None if e.content is None else e.content[0][cols]
    return Branches(new_lam, a_c[:, cols], prev.lag or bool(lag), new_content), check


def assign_numpy(prev: Branches, e: EigData, weight: float, omega: np.ndarray) -> tuple[Branches, StepCheck]:
    """``assign`` in numpy and scipy (Hungarian assignment by ``linear_sum_assignment``): the reference of the
    compiled kernel.

    Cost: (1 - MAC of the normalized structural vectors) + weight x eigenvalue distance relative to
    max(|s_prev|, omega_j) (a branch heading for s = 0 keeps a finite scale) + W_CONTENT x (0.5 - structural
    content)+ of the candidate (content counted 0 beyond VEER_DIST, and the term left out near s = 0) +
    LAG_PENALTY for a lag-root candidate (``eigen.lag_mask``). ZOH eigenvalues are unwrapped by the alias period.
    """
    assert e.xs is not None
    lam_c, a_c, period = e.lam[0], e.xs[0], float(e.period[0])
    k = prev.lam.size
    if math.isfinite(period):
        s = lam_c[None, :] + (1j * period) * np.round((prev.lam.imag[:, None] - lam_c.imag[None, :]) / period)
    else:
        s = lam_c[None, :]
    mac = np.abs(prev.vec.conj().T @ a_c) ** 2
    dist = np.abs(s - prev.lam[:, None]) / np.maximum(np.abs(prev.lam), omega)[:, None]
    cost = (1.0 - mac) + weight * dist
    lag_c = np.zeros(lam_c.size, bool) if e.lag is None else e.lag[0]
    cost[:, lag_c] += LAG_PENALTY
    if e.content is not None:
        # of two close roots (a structural root veering with a lag root) the more structural one; a root farther
        # than VEER_DIST counts as content 0, so content never draws a branch away from a close continuation; not
        # near s = 0, where the participation of any root becomes aerodynamic (a divergence is structural); roots
        # of content above 0.5 pay nothing (a coalescence of two structural branches is left to MAC and distance)
        low = W_CONTENT * np.maximum(0.5 - e.content[0], 0.0)  # structural roots (content > 0.5): 0
        term = np.where(dist < VEER_DIST, low[None, :], 0.5 * W_CONTENT)
        away = (np.abs(prev.lam) > CONTENT_AWAY * omega)[:, None] & (np.abs(s) > CONTENT_AWAY * omega[:, None])
        if not away.all():
            term = np.where(away, term, 0.0)
        cost += term - term.min(axis=1, keepdims=True)  # per-row shift: the assignment is unchanged by it, and a
        # branch of low content (strongly aero-coupled) does not get inflated costs, which would fake near-ties
    if not np.isfinite(cost).all():
        cost[~np.isfinite(cost)] = 1e6
    _, cols = linear_sum_assignment(cost)  # row indices come back sorted (k <= number of candidates)
    idx = np.arange(k)
    chosen = cost[idx, cols].tolist()
    new_lam = s[idx, cols] if s.shape[0] == k else lam_c[cols]
    lag = bool(lag_c[cols].any())
    check = StepCheck(float(mac[idx, cols].min()), float(dist[idx, cols].max()), _tie_gap(cost, chosen, prev, omega),
                      lag)
    content = None if e.content is None else e.content[0][cols]
    return Branches(new_lam, a_c[:, cols], prev.lag or lag, content), check


def _may_cross(p: tuple[float, float, float], g: np.ndarray) -> bool:
    """True when some branch's damping could reach zero between p1 and p2 although g is stable at both ends.

    ``g`` [3, k] at (p0, p1, p2). The estimate of g inside (p1, p2) is the parabola through the three points
    (its vertex when it lies inside), with the error of the linear extrapolation from (p0, p1) to p2 as its
    uncertainty; a step is refined while that estimate plus its uncertainty reaches above ``HUMP_FLOOR``.
    The uncertainty falls with the square of the step, so the refinement ends unless a hump is there.
    Compiled: ``assignment.may_cross``.
    """
    g = np.asarray(g, dtype=float)
    return bool(may_cross(float(p[0]), float(p[1]), float(p[2]), g[0], g[1], g[2], _hump_consts()))


def _hump_consts() -> np.ndarray:
    """(G_UNSTABLE, HUMP_ERR, HUMP_FLOOR), read at each call (tests vary them)."""
    return np.array([G_UNSTABLE, HUMP_ERR, HUMP_FLOOR])


def _content_jump(prev: Branches, new: Branches, omega: np.ndarray) -> bool:
    """True when some oscillatory branch's structural content changes by more than CONTENT_JUMP in one step (a
    structural root and a lag root exchanging their character: refined so that the exchange is located; NaN
    content: not computed). Compiled: ``assignment.content_jump``."""
    if prev.content is None or new.content is None:
        return False
    return bool(content_jump(prev.lam, new.lam, prev.content, new.content, omega, CONTENT_AWAY, CONTENT_JUMP))


def _history(p: list[float], p1: float) -> int | None:
    """Index of the point that, with the last one, extrapolates to p1: the latest point at least a quarter of
    the step (p1 - p_last) before the last one; None when there is none (no extrapolation beyond 4 x the
    history)."""
    p0 = p[-1]
    h = 0.25 * (p1 - p0)
    for i in range(len(p) - 2, -1, -1):
        if p0 - p[i] >= h:
            return i
    return None


@dataclass
class Path:
    """The tracked path: every point (coarse and refined) in order, and which of them are coarse points."""

    p: list[float]
    states: list[Branches]
    x: list[float]  # continuation coordinate of every point (Sweep.x)
    coarse: list[int] = field(default_factory=list)
    first_unstable: int | None = None  # index into p of the first point with an unstable branch
    n_refined: int = 0  # eigen-solved refinement points

    @property
    def lag(self) -> bool:
        """Some branch was continued on a lag-root candidate somewhere on the path."""
        return any(st.lag for st in self.states)

    def g(self, i: int) -> np.ndarray:
        lam = self.states[i].lam
        return 2.0 * lam.real / np.abs(lam)


def in_band(lam: np.ndarray, v: float, c_ref: float, k_gate: float) -> np.ndarray:
    """Branches [k] (eigenvalues lam, rad/s, at true speed v m/s) whose reduced frequency |Im s| (c_ref / 2) / v is
    <= k_gate (inf: all of them)."""
    if math.isinf(k_gate):
        return np.ones(lam.shape, bool)
    return np.abs(lam.imag) * 0.5 * c_ref <= k_gate * v




class Tracker:
    """Continuation of the structural branches along a sweep (module docstring).

    The methods that need eigen-data are generators: they yield ``eigen.EigRequest`` and receive EigData
    (``batch.run_searches`` answers the requests of many searches with one batched eigen-solve).
    """

    split_fractions: tuple[float, ...] = (0.25, 0.5, 0.75)  # interior points of a refined step (fractions)
    post_crossing_depth = POST_CROSSING_DEPTH  # split levels of an ambiguous step after the first unstable point
    vg_checks = True  # the eigen tracker checks every step with a full solve anyway

    def __init__(self, model: Model, sweep: Sweep, weight: float, k_gate: float = math.inf):
        self.m = model
        self.sweep = sweep
        self.weight = weight
        self.k_gate = float(k_gate)  # band above which an unstable branch is not counted (``unstable``)

    def in_band(self, p: float, state: Branches) -> np.ndarray:
        """``in_band`` of the branches of ``state`` at the sweep parameter p [k]."""
        v = float(self.sweep.cond(np.array([p]))[0][0]) if math.isfinite(self.k_gate) else 1.0
        return in_band(state.lam, v, self.m.c_ref, self.k_gate)

    def unstable(self, p: float, state: Branches) -> np.ndarray:
        """Branches of ``state`` at the sweep parameter p that count as unstable [k]: g > ``G_UNSTABLE`` and in the
        band (docs/flutter.md 9.10)."""
        return (2.0 * state.lam.real / np.abs(state.lam) > G_UNSTABLE) & self.in_band(p, state)

    def start(self) -> Branches:
        """The branch state at p_start (q = 0): the in-vacuo poles."""
        return initial_branches(self.m.omega, self.m.zeta)

    def eig(self, p: np.ndarray, vectors: bool = True) -> Solve[EigData]:
        """Eigen-data at the sweep parameters p (with their continuation coordinates)."""
        v, rho = self.sweep.cond(p)
        e = yield EigRequest(self.m, v, 0.5 * rho * v**2, vectors)
        e.x = self.sweep.x(p, v, rho)
        return e

    def step(self, prev: Branches, p0: float, p1: float, e1: EigData, depth: int = 0) -> Solve[Branches]:
        """Track from p0 (state prev) to p1 (eigen-data e1 of that point); an ambiguous step is split at
        ``split_fractions`` (one batched eigen-solve of the interior points; four sub-steps here, two in the
        continuation), at most ``post_crossing_depth`` times."""
        path = Path([p0], [prev], [0.0], first_unstable=0)  # careful refinement off (x unused)
        yield from self._advance(path, p1, e1, depth)
        return path.states[-1]

    def track(self, grid: np.ndarray) -> Path:
        """``track_search`` run on its own (one search)."""
        from .batch import run_one

        return run_one(self.track_search(grid))

    def track_search(self, grid: np.ndarray) -> Solve[Path]:
        """The path over the coarse grid from the in-vacuo poles at p_start, refined where needed.

        The sweep's fixed start points below the first grid point are tracked first (with the zero-order-hold
        coupling only those above its aliasing speed, ``Model.min_speed``); only the grid points are marked as
        coarse (reported) points.
        """
        start = self.sweep.start_points()
        start = start[(start < grid[0]) & (self.sweep.cond(start)[0] > self.m.min_speed)]
        pts = np.concatenate([start, grid])
        eg = yield from self.eig(pts)
        p0 = np.array([self.sweep.p_start])
        path = Path([self.sweep.p_start], [self.start()], [float(self.sweep.x(p0, *self.sweep.cond(p0))[0])])
        for i in range(pts.size):
            yield from self._advance(path, float(pts[i]), eg.point(i), 0)
            if i >= start.size:
                path.coarse.append(len(path.p) - 1)
        return path

    def _split(self, path: Path, p1: float, x1: float, careful: bool, check: StepCheck, new: Branches,
               depth: int) -> bool:
        """Whether the step from the path's last point to p1 (coordinate x1, state ``new``) must be refined."""
        p0 = path.p[-1]
        if not careful:
            return check.ambiguous and depth < self.post_crossing_depth
        if p1 - p0 <= self.sweep.min_step(p0) or path.n_refined >= MAX_REFINE_POINTS:
            return False
        if check.ambiguous or _content_jump(path.states[-1], new, self.m.omega):
            return True
        i = _history(path.x, x1)
        if i is None:
            return len(path.p) > 2  # a step too long for the history to check it: refine (not the first one)
        # s1 off the linear extrapolation from (x_i, x_last), or a damping hump (_may_cross) inside the step; not
        # the hump from i = 0: g is not smooth in p at q = 0 (e.g. g ~ V^3 in a constant-density sweep)
        return bool(not_smooth_or_hump(path.states[i].lam, path.states[-1].lam, new.lam, path.x[i], path.x[-1], x1,
                                       self.m.omega, i != 0, np.array([SMOOTH_TOL, *_hump_consts()])))

    def _advance(self, path: Path, p1: float, e1: EigData, depth: int) -> Solve[None]:
        """Append the point p1 (eigen-data e1) to the path, refining the step at ``split_fractions`` when needed."""
        new, check = assign(path.states[-1], e1, self.weight, self.m.omega)
        careful = path.first_unstable is None
        x1 = 0.0 if e1.x is None else float(e1.x[0])
        if self._split(path, p1, x1, careful, check, new, depth):
            p0 = path.p[-1]
            ps = p0 + (p1 - p0) * np.asarray(self.split_fractions)
            em = yield from self.eig(ps)
            path.n_refined += ps.size
            for i in range(ps.size):
                yield from self._advance(path, float(ps[i]), em.point(i), depth + 1)
            yield from self._advance(path, p1, e1, depth + 1)
            return
        path.p.append(p1)
        path.x.append(x1)
        path.states.append(new)
        if careful and np.any(self.unstable(p1, new)):
            path.first_unstable = len(path.p) - 1
