"""The first zero crossing of Re(s) on a structural branch, refined by Brent's method (``brentq``).

Every branch that first goes unstable (g > 1e-9) inside the first unstable interval is refined; the lowest
crossing wins. With the fast Tustin path the branch eigenvalue inside brentq is the Newton root of det T(s),
started from the linear interpolation between the nearest points of that branch known on either side; each
refined crossing is then checked against one full eigen-solve (the eigenvalue nearest the linear prediction
must be the Newton root to 1e-8), else brentq reruns on full eigen-solves. ``brentq`` here is
``scipy.optimize.brentq``'s algorithm step for step (same iterates), written as a generator so that the
function evaluations of many searches are answered together (batch.py).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .eigen import EigData
from .newton import NoRoot, RootRequest
from .tracking import G_UNSTABLE, Branches, Path, Solve, Tracker

BRENTQ_MAXITER = 100  # scipy.optimize.brentq's default
POLISH_TOL = 1e-11  # secant polish of brentq's crossing: last step below this (relative)
POLISH_MAXIT = 8


def brentq(f: Callable[[float], Solve[float]], xa: float, xb: float, xtol: float, rtol: float,
           maxiter: int = BRENTQ_MAXITER) -> Solve[float]:
    """Root of f in [xa, xb] by scipy.optimize.brentq's algorithm (its C code, step for step); f yields requests.

    Raises ValueError when f(xa), f(xb) have the same sign or f is NaN, RuntimeError when not converged.
    """
    xpre, xcur = xa, xb
    xblk = fblk = spre = scur = 0.0
    fpre = yield from _fval(f, xpre)
    fcur = yield from _fval(f, xcur)
    if fpre == 0:
        return xpre
    if fcur == 0:
        return xcur
    if math.copysign(1.0, fpre) == math.copysign(1.0, fcur):
        raise ValueError("f(a) and f(b) must have different signs")
    for _ in range(maxiter):
        if fpre != 0 and fcur != 0 and math.copysign(1.0, fpre) != math.copysign(1.0, fcur):
            xblk, fblk = xpre, fpre
            spre = scur = xcur - xpre
        if abs(fblk) < abs(fcur):
            xpre, xcur, xblk = xcur, xblk, xcur
            fpre, fcur, fblk = fcur, fblk, fcur
        delta = (xtol + rtol * abs(xcur)) / 2
        sbis = (xblk - xcur) / 2
        if fcur == 0 or abs(sbis) < delta:
            return xcur
        if abs(spre) > delta and abs(fcur) < abs(fpre):
            if xpre == xblk:
                stry = -fcur * (xcur - xpre) / (fcur - fpre)  # interpolate
            else:  # extrapolate
                dpre = (fpre - fcur) / (xpre - xcur)
                dblk = (fblk - fcur) / (xblk - xcur)
                stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre))
            if 2 * abs(stry) < min(abs(spre), 3 * abs(sbis) - delta):
                spre, scur = scur, stry  # good short step
            else:
                spre = scur = sbis  # bisect
        else:
            spre = scur = sbis  # bisect
        xpre, fpre = xcur, fcur
        xcur += scur if abs(scur) > delta else (delta if sbis > 0 else -delta)
        fcur = yield from _fval(f, xcur)
    raise RuntimeError(f"brentq: failed to converge after {maxiter} iterations, value is {xcur}")


def _fval(f: Callable[[float], Solve[float]], x: float) -> Solve[float]:
    """f(x) as a float; NaN raises ValueError (as scipy's brentq)."""
    y = float((yield from f(x)))
    if math.isnan(y):
        raise ValueError(f"The function value at x={x:f} is NaN; solver cannot continue.")
    return y


@dataclass
class Bracket:
    """The interval [lo_p, hi_p] with the tracked states at its ends and the candidate branches."""

    lo_p: float
    lo_state: Branches
    hi_p: float
    hi_state: Branches
    cands: list[int]
    known: dict[int, list[tuple[float, complex]]] = field(default_factory=dict)
    roots: dict[tuple[int, float], complex] = field(default_factory=dict)

    def pred(self, p: float, j: int) -> complex:
        """Linear prediction of branch j's eigenvalue at p between the bracket ends."""
        a, b = self.lo_state.lam[j], self.hi_state.lam[j]
        return complex(a + (p - self.lo_p) / (self.hi_p - self.lo_p) * (b - a))


def make_bracket(tracker: Tracker, path: Path, cands: np.ndarray | None = None) -> Solve[Bracket]:
    """Bracket of the first crossing: the path's first unstable point and the point before it.

    The candidates are the branches unstable at that point (none was unstable before), or ``cands`` [k] where the
    band gate chose them (``analysis.counted_onset``). A crossing before the
    first point after q = 0 is bracketed from the start state just after q = 0 (``Sweep.start_state_point``;
    a branch of zero structural damping has Re(s) = 0 exactly at q = 0); every branch with Re(s) > 0 there is
    a candidate too, unstable from the start of the sweep and reported there.
    """
    i = path.first_unstable
    assert i is not None and i >= 1
    hi_p, hi_state = path.p[i], path.states[i]
    unstable = path.g(i) > G_UNSTABLE if cands is None else cands
    if i == 1:
        sw = tracker.sweep
        lo_p = min(sw.start_state_point(), 0.5 * (sw.p_start + hi_p))
        e_lo = yield from tracker.eig(np.array([lo_p]))
        lo_state = yield from tracker.step(tracker.start(), sw.p_start, lo_p, e_lo)
        if cands is None:
            unstable |= lo_state.lam.real > 0
    else:
        lo_p, lo_state = path.p[i - 1], path.states[i - 1]
    return Bracket(lo_p, lo_state, hi_p, hi_state, [int(j) for j in np.nonzero(unstable)[0]])


ReFn = Callable[[float, int], Solve[float]]


def _re_eig(tracker: Tracker, br: Bracket) -> ReFn:
    """Re(s) of a branch at p from a full eigen-solve, matched to the bracket ends' linear prediction."""

    def f(p: float, j: int) -> Solve[float]:
        if p == br.lo_p:
            return float(br.lo_state.lam[j].real)
        if p == br.hi_p:
            return float(br.hi_state.lam[j].real)
        e = yield from tracker.eig(np.array([p]), vectors=False)
        lam, per = e.lam[0], float(e.period[0])
        pred = br.pred(p, j)
        if math.isfinite(per):
            lam = lam + 1j * per * np.round((pred.imag - lam.imag) / per)
        return float(lam[int(np.nanargmin(np.abs(lam - pred)))].real)

    return f


def _re_newton(tracker: Tracker, br: Bracket) -> ReFn:
    """Re(s) of a branch at p from a Newton root of det T(s) (no eigen-solve); raises NoRoot."""
    m = tracker.m

    def f(p: float, j: int) -> Solve[float]:
        if p == br.lo_p:
            return float(br.lo_state.lam[j].real)
        if p == br.hi_p:
            return float(br.hi_state.lam[j].real)
        pts = br.known.setdefault(j, [(br.lo_p, complex(br.lo_state.lam[j])),
                                      (br.hi_p, complex(br.hi_state.lam[j]))])
        pa, sa = max((x for x in pts if x[0] < p), key=lambda x: x[0])
        pb, sb = min((x for x in pts if x[0] > p), key=lambda x: x[0])
        start = sa + (p - pa) / (pb - pa) * (sb - sa)
        v, rho = tracker.sweep.cond(np.array([p]))
        s = yield RootRequest(m, float(v[0]) / m.c_ref, 0.5 * float(rho[0]) * float(v[0]) ** 2, start,
                              max(abs(start), float(m.omega[j])))
        if s is None:
            raise NoRoot(f"no convergence from {start}")
        br.roots[(j, p)] = s
        pts.append((p, s))
        return float(s.real)

    return f


def _refine(br: Bracket, f: ReFn, rtol: float) -> Solve[list[float]]:
    """Crossing p of each candidate branch with the Re(s) function f (brentq to rtol)."""
    scale = max(abs(br.hi_p), abs(br.lo_p), 1e-300)
    out = []
    for jb in br.cands:
        f_lo = yield from f(br.lo_p, jb)
        if f_lo > 0:
            out.append(br.lo_p)
        else:
            def fj(p: float, jb: int = jb) -> Solve[float]:
                return (yield from f(p, jb))

            p_b = yield from brentq(fj, br.lo_p, br.hi_p, rtol * scale * 1e-3, max(rtol, 1e-14))
            out.append((yield from _polish(fj, p_b, br.lo_p, br.hi_p, rtol)))
    return out


def _polish(f: Callable[[float], Solve[float]], p_b: float, lo: float, hi: float, rtol: float) -> Solve[float]:
    """brentq's crossing p_b polished by secant steps on f to ``POLISH_TOL`` relative, so that the crossing does not
    depend on the bracket (i.e. on the tracked path); p_b itself when the secant leaves (lo, hi) or stalls, the
    point of smallest |f| when f reaches its rounding level first."""
    step = rtol * max(abs(p_b), 1e-300)
    x0, x1 = p_b, p_b - step if p_b - step > lo else p_b + step
    if not lo < x1 < hi:
        return p_b
    f0 = yield from _fval(f, x0)
    f1 = yield from _fval(f, x1)
    best, f_best = (x0, f0) if abs(f0) <= abs(f1) else (x1, f1)
    for _ in range(POLISH_MAXIT):
        if f1 == f0:
            return best
        x2 = x1 - f1 * (x1 - x0) / (f1 - f0)
        if not lo < x2 < hi:
            return p_b
        f2 = yield from _fval(f, x2)
        if abs(f2) < abs(f_best):
            best, f_best = x2, f2
        if abs(x2 - x1) <= POLISH_TOL * abs(x2) or f2 == 0.0:
            return best
        x0, f0, x1, f1 = x1, f1, x2, f2
    return best  # f at its rounding level (e.g. eigenvalues of full eigen-solves): the smallest |f| seen


def _refine_fast(tracker: Tracker, br: Bracket, rtol: float) -> Solve[tuple[list[float], EigData | None] | None]:
    """Newton-based refinement, checked against one full eigen-solve per crossing; None when it fails."""
    try:
        p_js = yield from _refine(br, _re_newton(tracker, br), rtol)
    except NoRoot:
        return None
    chk = [(jb, pj) for jb, pj in zip(br.cands, p_js, strict=True) if pj != br.lo_p]
    eig_f = None
    if chk:
        e = yield from tracker.eig(np.array([pj for _, pj in chk]))
        for i, (jb, pj) in enumerate(chk):
            s = br.roots.get((jb, pj))
            lam = e.lam[i]
            near = lam[int(np.nanargmin(np.abs(lam - br.pred(pj, jb))))]
            if s is None or abs(near - s) > 1e-8 * max(abs(s), float(tracker.m.omega[jb])):
                return None
            if pj == min(p_js):
                eig_f = e.point(i)
    return p_js, eig_f


def refine_crossing(tracker: Tracker, br: Bracket, rtol: float) -> Solve[tuple[float, int, Branches]]:
    """(p_f, flutter branch index, branch state at p_f) of the lowest crossing inside the bracket."""
    res = (yield from _refine_fast(tracker, br, rtol)) if tracker.m.lam_a is not None else None
    if res is None:
        p_js, eig_f = (yield from _refine(br, _re_eig(tracker, br), rtol)), None
    else:
        p_js, eig_f = res
    # lowest crossing; among branches unstable from the bracket start, the most unstable one there
    lo = br.lo_state.lam
    p_f, branch = min(zip(p_js, br.cands, strict=True), key=lambda x: (x[0], -lo[x[1]].real / abs(lo[x[1]])))
    e_f = (yield from tracker.eig(np.array([p_f]))) if eig_f is None else eig_f
    st_f = yield from tracker.step(br.lo_state, br.lo_p, p_f, e_f)
    return p_f, branch, st_f
