"""Plot-only V-g / V-f curves of a flutter search: from q = 0, every tracked point, refined near each crossing.

The coarse V-g data of a result (``FlutterResult.v``, ``g``, ...) start at the first sweep point. The curves here
add what the tracker computed anyway -- the in-vacuo poles at q = 0 (frequencies omega_i, g = -2 zeta_i), the
fixed start points, every refinement point and the flutter point itself -- and, for the plot only, a few tracked
points inside each later interval where a branch's damping changes sign (Newton roots of det T(s) from the
interval's end states when the tracker's steps are compiled, else one batched eigen-solve for all of them).
Nothing here feeds back into the flutter point: the search has finished before these points are solved.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import newton_kernel as nk
from .batch import STATS
from .eigen import CONTENT_MIN
from .sweeps import eas
from .tracking import G_UNSTABLE, Branches, Path, Solve, Tracker, assign

CROSSING_POINTS = 5  # plot-only tracked points inside each later sign-change interval of g


@dataclass
class VgCurves:
    """V-g / V-f curves over n points in sweep order from q = 0 (SI units, rad/s); branch data [n, k].

    ``v`` is the sweep's speed axis (as ``FlutterResult.v``), ``v_true`` the true airspeed, ``v_eas`` =
    sqrt(2 q / rho_0); ``g`` = 2 Re(s)/|s|, ``omega`` = Im(s). ``kind`` [n]: 0 in-vacuo point (q = 0), 1 coarse
    sweep point, 2 tracker refinement or start point, 3 flutter point, 4 plot-only point near a later crossing.
    """

    q: np.ndarray = field(default_factory=lambda: np.zeros(0))
    v: np.ndarray = field(default_factory=lambda: np.zeros(0))
    v_true: np.ndarray = field(default_factory=lambda: np.zeros(0))
    v_eas: np.ndarray = field(default_factory=lambda: np.zeros(0))
    rho: np.ndarray = field(default_factory=lambda: np.zeros(0))
    altitude: np.ndarray = field(default_factory=lambda: np.zeros(0))
    g: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    omega: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    kind: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int8))


def _crossing_intervals(p: np.ndarray, g: np.ndarray, p_f: float | None) -> list[int]:
    """Indices i of the intervals (p_i, p_i+1) where some branch's g changes sign (not at q = 0, and not the
    flutter crossing's interval, which brentq has refined)."""
    unstable = g > G_UNSTABLE
    idx = np.flatnonzero(np.any(unstable[1:] != unstable[:-1], axis=1))
    return [int(i) for i in idx if i > 0 and not (p_f is not None and p[i] <= p_f <= p[i + 1])]


def vg_curves(tracker: Tracker, path: Path, flutter: tuple[float, Branches] | None) -> Solve[VgCurves]:
    """The plot curves of a finished search (``path``; ``flutter`` = (p_f, state there) or None)."""
    p = list(path.p)
    states = list(path.states)
    kind = [2] * len(p)
    kind[0] = 0
    for i in path.coarse:
        kind[i] = 1
    if flutter is not None:
        j = int(np.searchsorted(np.asarray(p), flutter[0]))
        p.insert(j, flutter[0])
        states.insert(j, flutter[1])
        kind.insert(j, 3)
    lam = np.array([st.lam for st in states])
    pa = np.asarray(p, float)
    cross = _crossing_intervals(pa, 2.0 * lam.real / np.abs(lam), None if flutter is None else flutter[0])
    if cross:
        frac = np.arange(1, CROSSING_POINTS + 1) / (CROSSING_POINTS + 1.0)
        pts = np.concatenate([pa[i] + (pa[i + 1] - pa[i]) * frac for i in cross])
        extra_lam = _newton_points(tracker, pts, [(states[i].lam, states[i + 1].lam) for i in cross], frac)
        if extra_lam is None:
            e = yield from tracker.eig(pts)
            extra_lam = []
            for n, i in enumerate(cross):
                prev = states[i]
                for m in range(CROSSING_POINTS):
                    prev, _ = assign(prev, e.point(n * CROSSING_POINTS + m), tracker.weight, tracker.m.omega)
                    extra_lam.append(prev.lam)
        pa = np.concatenate([pa, pts])
        lam = np.concatenate([lam, np.array(extra_lam)])
        kind += [4] * pts.size
    order = np.argsort(pa, kind="stable")
    return _curves(tracker, pa[order], lam[order], np.asarray(kind, np.int8)[order])


def _newton_points(tracker: Tracker, pts: np.ndarray, ends: list[tuple[np.ndarray, np.ndarray]],
                   frac: np.ndarray) -> list[np.ndarray] | None:
    """Branch roots [k] at the plot-only points ``pts`` by Newton on det T(s) (``newton_kernel.roots_vectors``) from
    the linear interpolation of the interval's end states ``ends`` (CROSSING_POINTS points per interval at ``frac``)
    when the tracker's steps are compiled (``continuation.kernel_sweep``); None (the eigen-solves decide)
    otherwise, or when a root does not converge, lands farther than ``PRED_TOL_POST`` from its prediction or two
    branches meet."""
    from .continuation import PRED_TOL_POST, ContinuationTracker, branches_meet, kernel_sweep

    m = tracker.m
    if not isinstance(tracker, ContinuationTracker) or kernel_sweep(m, tracker.sweep) is None:
        return None
    pred = np.concatenate([lo[None, :] + frac[:, None] * (hi - lo)[None, :] for lo, hi in ends])  # [n, k]
    scale = np.concatenate([np.repeat(np.maximum(np.abs(lo), m.omega)[None, :], frac.size, axis=0)
                            for lo, _ in ends])
    v, rho = tracker.sweep.cond(pts)
    k = m.k
    vc, q = np.repeat(v / m.c_ref, k), np.repeat(0.5 * rho * v**2, k)
    roots, found, *_ = nk.roots_vectors(pred.ravel(), scale.ravel(), vc, q, np.zeros(vc.size, bool),
                                        *nk.model_args(m), CONTENT_MIN, 30)
    STATS.newton_roots += vc.size
    lam = roots.reshape(pred.shape)
    if not found.all() or np.max(np.abs(lam - pred) / scale) > PRED_TOL_POST or branches_meet(lam, scale):
        return None
    return list(lam)


def _curves(tracker: Tracker, p: np.ndarray, lam: np.ndarray, kind: np.ndarray) -> VgCurves:
    """VgCurves of sweep parameters p [n] with branch eigenvalues lam [n, k]."""
    sw = tracker.sweep
    v, rho = sw.cond(p)
    q = 0.5 * rho * v**2
    with np.errstate(invalid="ignore", divide="ignore"):
        g = 2.0 * lam.real / np.abs(lam)
    return VgCurves(q=q, v=sw.speed_axis(v, q), v_true=v, v_eas=eas(q), rho=rho, altitude=sw.altitude(p),
                    g=g, omega=lam.imag, kind=kind)
