"""Continuation of the structural branches in p by Newton on det T(s), with full eigen-solves only where needed.

``ContinuationTracker`` builds the same ``tracking.Path`` as ``Tracker`` (the coarse points, the states, the first
unstable point), but reaches the points by predictor-corrector steps instead of one eigen-solve per point:

- predictor: the quadratic (or, with less history, linear) extrapolation of each branch's eigenvalue in the
  continuation coordinate x (``Sweep.x``) through the last points of the path;
- corrector: Newton on det T(s) from the prediction for the k branches together (one ``newton.RootsRequest``,
  iterated with the requests of every other search of the round, ``batch.py``); the structural vectors, content and
  lag flags of the k roots come from the null vectors of T(s) (``newton.roots_and_vectors``, batched as well);
- a step is accepted when every branch converged to its own root (no two branches on the same root), each root
  lies within ``PRED_TOL`` (relative) of its prediction, keeps MAC >= ``MAC_STEP`` with the previous vector, is no
  lag root and changes its structural content by less than ``tracking.CONTENT_JUMP``; before the first unstable
  point a step where a branch of structural content below 0.5 loses more of it (veering with a lag root) goes to the
  full spectrum at once (its assignment's content terms choose the more structural root, as ``Tracker`` does), and
  the damping-hump test ``tracking._may_cross`` must pass (a crossing between two stable points is
  not skipped), down to the sweep's minimum step. The step grows (x 2) when the corrector lands close to the
  predictor and shrinks (/ 4) on a rejected step;
- a full eigen-solve resolves what Newton cannot: a step rejected at the smallest Newton step ``H_MIN`` (of the
  natural range) is taken by ``Tracker._advance`` (Hungarian assignment of the full spectrum, its split rules,
  with the step halved where it quarters it: ``split_fractions``),
  and after ``FALLBACKS`` such steps in a row the rest of the way to the next target point as well;
  and at the fixed checkpoints ``CHECKPOINTS`` (fractions of the sweep's range, independent of the coarse grid)
  the Newton states are compared, after the sweep and in one eigen-solve request, with the assignment of the full
  spectrum from the point before each (with ``vg_checks`` False only those that can change the flutter point,
  ``_deciding``); at the first that differs (a root that entered between the branches, or a
  branch that slid onto another root) the path is cut, the full-spectrum step replaces the Newton one and the
  continuation resumes from there.

Compiled steps (``newton_kernel``, docs/flutter.md 9.9): with a diagonalized aero matrix the Newton steps between
full eigen-solves run in numba (``_run_compiled``: whole segments for the constant-speed and constant-density
sweeps; ``_kernel_point``: one step per call for the matched sweep), with the same predictor, corrector and tests;
``newton_kernel.ENABLED = False`` runs the numpy steps below, their reference.

A Tustin model whose aero matrix is not diagonalized (defective, the reference path) gets T(s) from dense solves
with s* I - A (``eigen.resolvent_terms``), so both paths continue the branches alike; the zero-order hold has no
det T(s) of this form and uses ``Tracker`` unchanged.
"""

from __future__ import annotations

import numpy as np

from . import newton_kernel as nk
from .batch import STATS
from .eigen import CONTENT_MIN, EigData
from .model import Model
from .newton import RootRequest, RootsRequest
from .sweeps import ConstantDensity, ConstantSpeed, Sweep
from .tracking import (
    CONTENT_AWAY,
    CONTENT_JUMP,
    G_UNSTABLE,
    HUMP_ERR,
    HUMP_FLOOR,
    POST_CROSSING_DEPTH,
    Branches,
    Path,
    Solve,
    Tracker,
    _content_jump,
    _may_cross,
    assign,
)

PRED_TOL = 0.05  # corrector farther than this (relative to max(|s|, omega_j)) from the predictor: step rejected
PRED_TOL_POST = 0.3  # the same after the first unstable point (the steps there only shape the V-g curves)
GROW = 8.0  # corrector within PRED_TOL / GROW of the predictor: next step doubled
MAC_STEP = 0.9  # smallest MAC of a branch's vector with its previous one on an accepted Newton step
SAME_ROOT = 1e-6  # two branches closer than this (relative) sit on the same root
H_MIN = 2.0**-9  # smallest Newton step (of the natural range) before a full eigen-solve resolves the step
CHECKPOINTS = (0.25, 0.5, 1.0)  # fractions of the sweep range where the Newton state is checked by a full solve
MATCH_TOL = 1e-6  # Newton root and full-spectrum assignment agree to this (relative)
VEER_DROP = 0.002  # content loss in one step of a branch below content 0.5 that sends the step to the full spectrum
SEGMENT_ROOM = 256  # accepted points one compiled segment may return before it hands back (and is called again)
FALLBACKS = 4  # full-spectrum steps of length H_MIN in a row after which the full spectrum takes the step to the target


HUMP = "hump"  # rejection of a step by the damping-hump test (shrinks to the sweep's minimum step, no eigen-solve)
FULL = "full"  # a step the full spectrum must take at once (a branch of structural content below 0.5)


def branches_meet(lam: np.ndarray, scale: np.ndarray) -> bool:
    """True when two branch roots of some row of lam [..., k] (rad/s) sit on one root or on a conjugate pair (closer
    than ``SAME_ROOT`` relative to ``scale`` [..., k]): a root and its conjugate are one mode pair."""
    d = np.minimum(np.abs(lam[..., :, None] - lam[..., None, :]), np.abs(lam[..., :, None] - lam[..., None, :].conj()))
    return bool(np.min(d / scale[..., :, None] + np.eye(lam.shape[-1])) < SAME_ROOT)


def kernel_sweep(model: Model, sweep: Sweep) -> tuple[int, float] | None:
    """(``newton_kernel`` sweep kind, its parameter) when the compiled steps apply (kernels enabled, diagonalized
    aero matrix, constant-speed or constant-density sweep), else None (the steps of ``_continue_to``)."""
    if not nk.ENABLED or model.lam_a is None:
        return None
    if type(sweep) is ConstantSpeed:
        return nk.CONSTANT_SPEED, float(sweep.v0)
    if type(sweep) is ConstantDensity:
        return nk.CONSTANT_DENSITY, float(sweep.rho_ref)
    return None


def _step_consts() -> np.ndarray:
    """The acceptance constants of a compiled step after its predictor tolerance (``newton_kernel.newton_point``),
    read at each call (tests vary them)."""
    return np.array([SAME_ROOT, MAC_STEP, CONTENT_JUMP, CONTENT_AWAY, VEER_DROP, CONTENT_MIN, G_UNSTABLE, HUMP_ERR,
                     HUMP_FLOOR])


def _deciding(path: Path, marks: list[int]) -> list[int]:
    """The checkpoints (path indices ``marks``) that can change the flutter point: all before the first unstable
    point and the first at or after it, which catches a slide before the crossing that lasts to it; the later ones
    check only the V-g curves after the crossing (docs/performance.md 6c)."""
    fu = path.first_unstable
    if fu is None:
        return marks
    return [i for i in marks if i < fu] + [i for i in marks if i >= fu][:1]


class ContinuationTracker(Tracker):
    """Branch continuation by Newton on det T(s) (module docstring); ``Tracker`` for models without it."""

    newton_last = False  # the path's last point came from a Newton step (not yet checked by a full solve)
    # the full-spectrum steps it hands over are halved, not quartered, when they must be refined: 2.4 instead of 4.1
    # eigen-solves per Mach on the cropped delta's DLM ROMs, the same flutter points (docs/performance.md 6c); twice
    # the levels after the crossing keep the eigen tracker's finest post-crossing step
    split_fractions = (0.5,)
    post_crossing_depth = 2 * POST_CROSSING_DEPTH
    vg_checks = True  # False: skip the checkpoints that check only the V-g curves after the crossing (``_deciding``)

    def track_search(self, grid: np.ndarray) -> Solve[Path]:
        """The path over the coarse grid (``Tracker.track_search``'s points and result), by continuation."""
        m = self.m
        if m.coupling != "tustin":
            return (yield from super().track_search(grid))
        sw = self.sweep
        start = sw.start_points()
        start = start[start < grid[0]]
        span = sw.p_end - sw.p_start
        pts = np.concatenate([start, grid])
        checks = sw.p_start + span * np.array(CHECKPOINTS)
        near = np.abs(checks[:, None] - pts[None, :]) <= 1e-9 * span  # a checkpoint on a target point: that point
        checks = np.where(near.any(axis=1), pts[np.argmax(near, axis=1)], checks)
        pts = np.union1d(pts, checks)
        coarse = set(grid.tolist())
        check_set = set(checks.tolist())
        p0 = np.array([sw.p_start])
        path = Path([sw.p_start], [self.start()], [float(sw.x(p0, *sw.cond(p0))[0])])
        h = float(pts[0] - sw.p_start)
        todo = pts
        while True:
            marks = yield from self._run(path, todo.tolist(), coarse, check_set, h)
            bad = yield from self._verify(path, marks if self.vg_checks else _deciding(path, marks))
            if bad is None:
                return path
            i, e_c = bad  # the checkpoint path.p[i] disagrees with the full spectrum: retrack from it
            p_c = path.p[i]
            del path.p[i:], path.states[i:], path.x[i:]
            path.coarse = [c for c in path.coarse if c < i]
            if path.first_unstable is not None and path.first_unstable >= i:
                path.first_unstable = None
            yield from self._advance(path, p_c, e_c, 0)
            self.newton_last = False
            if p_c in coarse:
                path.coarse.append(len(path.p) - 1)
            todo = pts[pts > p_c]
            h = p_c - path.p[-2]

    def _run(self, path: Path, todo: list[float], coarse: set[float], check_set: set[float],
             h: float) -> Solve[list[int]]:
        """Continue the path over the target points ``todo``; the path indices of the checkpoints reached by Newton."""
        sweep_kind = kernel_sweep(self.m, self.sweep)
        if sweep_kind is not None:
            return (yield from self._run_compiled(path, todo, coarse, check_set, h, sweep_kind))
        marks = []
        for p_t in todo:
            h = yield from self._continue_to(path, p_t, h)
            if p_t in check_set and self.newton_last:
                marks.append(len(path.p) - 1)
            if p_t in coarse:
                path.coarse.append(len(path.p) - 1)
        return marks

    def _run_compiled(self, path: Path, todo: list[float], coarse: set[float], check_set: set[float], h: float,
                      sweep_kind: tuple[int, float]) -> Solve[list[int]]:
        """``_run`` with the Newton steps of ``_continue_to`` in ``newton_kernel.segment`` (the same steps and
        tests); the steps it hands back are taken by the full spectrum here, as ``_continue_to`` takes them."""
        m, sw = self.m, self.sweep
        k = m.k
        consts = np.concatenate([[PRED_TOL, PRED_TOL_POST, GROW], _step_consts(), [self.k_gate]])
        targets = np.asarray(todo, float)
        marks: list[int] = []
        it, fails = 0, 0
        while it < targets.size:
            last = path.states[-1]
            n_hist = min(len(path.x), 3)
            xh = np.zeros(3)
            xh[3 - n_hist:] = path.x[-n_hist:]
            lamh = np.zeros((3, k), complex)
            lamh[3 - n_hist:] = [st.lam for st in path.states[-n_hist:]]
            has = last.content is not None
            end, it, h, fails, p1, pp, lam, vec, cont, tgt, first = nk.segment(
                targets, it, h, fails, path.p[-1], xh, lamh, n_hist, np.ascontiguousarray(last.vec, complex),
                np.ascontiguousarray(last.content, float) if has else np.zeros(k), has, len(path.p),
                path.first_unstable is None, *nk.model_args(self.m), sweep_kind[0], sweep_kind[1], m.c_ref,
                sw.min_step(path.p[-1]), H_MIN * sw.scale_at(path.p[-1]), FALLBACKS, consts, SEGMENT_ROOM)
            base = len(path.p)
            STATS.newton_roots += k * pp.size
            for i in range(pp.size):
                path.p.append(float(pp[i]))
                path.x.append(float(pp[i]))
                path.states.append(Branches(lam[i], vec[i], last.lag, cont[i]))
            if first >= 0 and path.first_unstable is None:
                path.first_unstable = base + int(first)
            if pp.size:
                self.newton_last = True
            for i in np.flatnonzero(tgt >= 0).tolist():
                p_t = todo[int(tgt[i])]
                if p_t in check_set:
                    marks.append(base + i)
                if p_t in coarse:
                    path.coarse.append(base + i)
            if end != nk.NEED_EIG:
                continue
            p0 = path.p[-1]  # the full spectrum takes the step (``_continue_to``)
            e1 = yield from self.eig(np.array([p1]))
            yield from self._advance(path, p1, e1, 0)
            self.newton_last = False
            h = p1 - p0
            if path.p[-1] >= todo[it]:  # it reached the target
                if todo[it] in coarse:
                    path.coarse.append(len(path.p) - 1)
                it, fails = it + 1, 0
        return marks

    def _verify(self, path: Path, marks: list[int]) -> Solve[tuple[int, EigData] | None]:
        """Check the checkpoints (path indices ``marks``) against one full eigen-solve of all of them: the first one
        whose Newton state is not the Hungarian assignment of the full spectrum from the point before it (index and
        its eigen-data), None when all agree."""
        if not marks:
            return None
        e = yield from self.eig(np.array([path.p[i] for i in marks]))
        for j, i in enumerate(marks):
            full, check = assign(path.states[i - 1], e.point(j), self.weight, self.m.omega)
            st = path.states[i]
            scale = np.maximum(np.abs(st.lam), self.m.omega)
            if check.ambiguous or np.max(np.abs(full.lam - st.lam) / scale) >= MATCH_TOL:
                return i, e.point(j)
        return None

    def _continue_to(self, path: Path, p_t: float, h: float) -> Solve[float]:
        """Advance the path to p_t by Newton steps (first step h); returns the next step length."""
        sw = self.sweep
        fails = 0
        while path.p[-1] < p_t:
            p0 = path.p[-1]
            p1 = p_t if p0 + 1.25 * h >= p_t else p0 + h
            res = yield from self._newton_point(path, p1)
            if isinstance(res, tuple):
                new, x1, err = res
                self._append(path, p1, x1, new)
                self.newton_last = True
                fails = 0
                h = max(h, p1 - p0) * (2.0 if err < self._pred_tol(path) / GROW else 1.0)  # a step cut short by
                # the target keeps the step length it came with
                continue
            if res != FULL and (p1 - p0 > H_MIN * sw.scale_at(p0) or res == HUMP):
                h = 0.25 * (p1 - p0)
                continue
            # Newton cannot resolve the step: the full-spectrum tracker takes it (and, after FALLBACKS such steps in
            # a row, the rest of the way to the target)
            fails += 1
            p1 = p_t if fails >= FALLBACKS else p1
            e1 = yield from self.eig(np.array([p1]))
            yield from self._advance(path, p1, e1, 0)
            self.newton_last = False
            h = p1 - p0
        return h

    @staticmethod
    def _pred_tol(path: Path) -> float:
        """Largest accepted predictor error: ``PRED_TOL`` before the first unstable point, ``PRED_TOL_POST`` after."""
        return PRED_TOL if path.first_unstable is None else PRED_TOL_POST

    def _append(self, path: Path, p1: float, x1: float, new: Branches) -> None:
        """Append an accepted point; mark the first unstable point."""
        careful = path.first_unstable is None
        path.p.append(p1)
        path.x.append(x1)
        path.states.append(new)
        if careful and np.any(self.unstable(p1, new)):
            path.first_unstable = len(path.p) - 1

    def _predict(self, path: Path, x1: float) -> np.ndarray:
        """Predicted branch eigenvalues [k] at coordinate x1 (quadratic / linear extrapolation in x)."""
        xs, st = path.x, path.states
        n = min(len(xs), 3)
        if n == 1:
            return st[-1].lam.copy()
        xa = xs[-n:]
        out = np.zeros(st[-1].lam.size, complex)
        for i in range(n):  # Lagrange basis through the last n points
            w = 1.0
            for j in range(n):
                if j != i:
                    w *= (x1 - xa[j]) / (xa[i] - xa[j])
            out += w * st[i - n].lam
        return out

    def _newton_point(self, path: Path, p1: float) -> Solve[tuple[Branches, float, float] | str | None]:
        """(state, x1, predictor error) of the Newton corrector at p1; None when the step is ambiguous, ``HUMP``
        when only the damping-hump test rejects it, ``FULL`` when the full spectrum must take it (``_veers``)."""
        m, sw = self.m, self.sweep
        v, rho = sw.cond(np.array([p1]))
        q = 0.5 * rho * v**2
        x1 = float(sw.x(np.array([p1]), v, rho)[0])
        prev = path.states[-1]
        if m.lam_a is not None and nk.ENABLED:  # diagonalized aero matrix: the compiled step (newton_kernel)
            return self._kernel_point(path, p1, x1, float(v[0]) / m.c_ref, float(q[0]))
        pred = self._predict(path, x1)
        scale = np.maximum(np.abs(prev.lam), m.omega)
        vc = float(v[0]) / m.c_ref
        roots, data = yield RootsRequest([RootRequest(m, vc, float(q[0]), complex(s0), float(sc))
                                          for s0, sc in zip(pred.tolist(), scale.tolist(), strict=True)])
        if any(d is None for d in data):
            return None
        lam = np.array(roots, complex)
        err = float(np.max(np.abs(lam - pred) / scale))
        if err > self._pred_tol(path) or branches_meet(lam, scale):
            return None
        if any(d[2] for d in data):  # a branch on a lag root
            return None
        vec = np.stack([d[0] for d in data], axis=1)
        content = np.array([d[1] for d in data])
        if float(np.min(np.abs(np.sum(prev.vec.conj() * vec, axis=0)) ** 2)) < MAC_STEP:
            return None
        new = Branches(lam, vec, prev.lag, content)
        if _content_jump(prev, new, m.omega):
            return None
        if path.first_unstable is None and self._veers(prev, new):
            return FULL
        if path.first_unstable is None and self._hump(path, p1, x1, new):
            return HUMP
        return new, x1, err

    def _kernel_point(self, path: Path, p1: float, x1: float, vc: float,
                      q: float) -> tuple[Branches, float, float] | str | None:
        """``_newton_point`` by the compiled step (``newton_kernel.newton_point``: the same tests, no yield)."""
        prev = path.states[-1]
        n = min(len(path.x), 3)
        k = prev.lam.size
        has = prev.content is not None
        content = np.ascontiguousarray(prev.content, float) if has else np.zeros(k)
        careful = path.first_unstable is None
        hump_ok = len(path.p) >= 3 and p1 - path.p[-1] > self.sweep.min_step(path.p[-1])
        consts = np.concatenate([[self._pred_tol(path)], _step_consts()])
        status, lam, vec, cont, err = nk.newton_point(
            np.array(path.x[-n:], float), np.array([st.lam for st in path.states[-n:]], complex), x1, vc, q,
            np.ascontiguousarray(prev.vec, complex), content, has, *nk.model_args(self.m), careful, hump_ok, consts)
        STATS.newton_roots += k
        if status == nk.ACCEPTED:
            return Branches(lam, vec, prev.lag, cont), x1, float(err)
        return {nk.HUMP: HUMP, nk.FULL: FULL}.get(int(status))

    def _veers(self, prev: Branches, new: Branches) -> bool:
        """True when an oscillatory branch of structural content below 0.5 loses more of it (by ``VEER_DROP``) in
        the step: it veers with a lag root (they exchange their character), which the full spectrum's assignment
        resolves (its content terms take the more structural root, as ``Tracker`` does)."""
        if prev.content is None or new.content is None:
            return False
        om = self.m.omega
        away = (np.abs(prev.lam) > CONTENT_AWAY * om) & (np.abs(new.lam) > CONTENT_AWAY * om)
        return bool(np.any(away & (new.content < 0.5) & (prev.content - new.content > VEER_DROP)))

    def _hump(self, path: Path, p1: float, x1: float, new: Branches) -> bool:
        """True when a branch's damping could cross zero inside the step (``_may_cross``) and the step can shrink."""
        if len(path.p) < 3 or p1 - path.p[-1] <= self.sweep.min_step(path.p[-1]):
            return False
        g_new = 2.0 * new.lam.real / np.abs(new.lam)
        xs = (path.x[-2], path.x[-1], x1)
        return _may_cross(xs, np.array([path.g(-2), path.g(-1), g_new]))
