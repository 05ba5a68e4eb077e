"""Newton roots of det T(s) on the Tustin fast path, many requests iterated together (crossing refinement).

The eigenvalue s (rad/s) of the coupled system at V / c_ref = vc, q is a root of det T(s), T(s) = s^2 I + s G + K
- q H(s) with H from the diagonalized aero matrix (``model.py``); the crossing refinement (``crossing.py``) asks
for such roots inside brentq instead of full eigen-solves. ``batch.py`` answers the requests of many searches
with one ``newton_roots`` call.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import newton_kernel as nk
from .eigen import CONTENT_MIN, EigRequest, null_vectors, resolvent_dense, resolvent_diag
from .model import Model


class NoRoot(Exception):
    """Newton on det T(s) did not converge (the caller falls back to eigen-solves)."""


@dataclass
class RootRequest:
    """A search's request for the Newton root of det T(s) of ``model`` at V/c_ref = vc (1/s), q (Pa) from s0 (rad/s)."""

    model: Model
    vc: float
    q: float
    s0: complex
    scale: float


@dataclass
class RootsRequest:
    """Several Newton roots at once (the k branches of a continuation step), of one shape (k, aero model size);
    answered by the list of roots and the list of their ``roots_and_vectors`` data."""

    reqs: list[RootRequest]


Request = EigRequest | RootRequest | RootsRequest


def newton_root(m: Model, vc: float, q: float, s0: complex, scale: float, maxit: int = 30) -> complex:
    """Eigenvalue s (rad/s) at V/c_ref = vc (1/s), q (Pa) by Newton on det T(s) from s0 (``newton_roots``, one root).

    Raises NoRoot when Newton does not converge.
    """
    s = newton_roots([RootRequest(m, vc, q, s0, scale)], maxit)[0]
    if s is None:
        raise NoRoot(f"no convergence from {s0}")
    return s


def _root_arrays(reqs: list[RootRequest]) -> dict[str, np.ndarray]:
    """Per-request parameters of Newton on det T(s), stacked (all requests have the same k and na)."""
    m0 = reqs[0].model
    k2 = m0.k * m0.k
    ms = [r.model for r in reqs]
    zero = np.zeros(k2)
    aero = ({"lam_a": np.array([m.lam_a for m in ms]), "res": np.array([m.res for m in ms])}
            if m0.lam_a is not None else
            {"a": np.array([m.a for m in ms]), "b": np.array([m.b for m in ms]), "c": np.array([m.c for m in ms]),
             "poles": np.array([m.poles for m in ms])})
    out = {
        **aero,
        "g": np.array([2.0 * m.zeta * m.omega for m in ms]), "kd": np.array([m.omega**2 for m in ms]),
        "omega": np.array([m.omega for m in ms]),
        "d": np.array([m.d.ravel() for m in ms]), "vc": np.array([r.vc for r in reqs], float),
        "q": np.array([r.q for r in reqs], float), "s": np.array([r.s0 for r in reqs], complex),
        "scale": np.array([r.scale for r in reqs], float),
    }
    if any(m.d1 is not None or m.d2 is not None for m in ms):
        out["d1"] = np.array([zero if m.d1 is None else m.d1.ravel() for m in ms])
        out["d2"] = np.array([zero if m.d2 is None else m.d2.ravel() for m in ms])
    return out


def _terms(a: dict[str, np.ndarray], i: np.ndarray,
           k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray, np.ndarray]:
    """T(s), the aero states' part of dT/ds (q / vc) C (s* I - A)^-2 B, the D1, D2 part of dT/ds (None without them)
    [n, k*k], and the on-pole / near-pole flags [n] of the requests i at their current s (``eigen.resolvent_terms``)."""
    s, vc, q = a["s"][i], a["vc"][i], a["q"][i]
    if "lam_a" in a:
        h1, h2, on_pole, near = resolvent_diag(s / vc, a["lam_a"][i], a["res"][i])
    else:
        h1, h2, on_pole, near = resolvent_dense(s / vc, a["a"][i], a["b"][i], a["c"][i], a["poles"][i])
    t = -q[:, None] * a["d"][i] - q[:, None] * h1
    t[:, :: k + 1] += s[:, None] * s[:, None] + a["g"][i] * s[:, None] + a["kd"][i]
    dta = (q / vc)[:, None] * h2
    dt_rate = None
    if "d1" in a:
        sv, qv = (s / vc)[:, None], (q / vc)[:, None]
        d1, d2 = a["d1"][i], a["d2"][i]
        t = t + -q[:, None] * (sv * d1 + sv * sv * d2)
        dt_rate = -qv * (d1 + 2.0 * sv * d2)
    return t, dta, dt_rate, on_pole, near


def _newton_system(a: dict[str, np.ndarray], i: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """T(s) and dT/ds [n, k, k] of the requests i at their current s (module docstring; D1, D2 as _rate_terms)."""
    t, dta, dt_rate, _, _ = _terms(a, i, k)
    dt = dta.copy()
    dt[:, :: k + 1] += 2.0 * a["s"][i][:, None] + a["g"][i]
    if dt_rate is not None:
        dt = dt + dt_rate
    return t.reshape(-1, k, k), dt.reshape(-1, k, k)


def _solve_each(t: np.ndarray, dt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(T^-1 dT/ds [n, k, k], exactly singular T [n]) one system at a time (after a batched solve failed)."""
    x = np.full(t.shape, np.nan, complex)
    sing = np.zeros(t.shape[0], bool)
    for i in range(t.shape[0]):  # the batched solve's routine, so that the other rows keep their bits
        try:
            x[i] = np.linalg.solve(t[i], dt[i])
        except np.linalg.LinAlgError:
            sing[i] = True
    return x, sing


def newton_roots(reqs: list[RootRequest], maxit: int = 30) -> list[complex | None]:
    """Newton roots of det T(s) (rad/s) for requests of one shape (k, na), all iterated together; None: no root.

    Step: s <- s - 1 / tr(T^-1 dT/ds) (d ln det T / ds), dT/ds = 2 s I + G + (q / vc) sum_i res_i r_i^2 with
    r_i = vc / (s - vc lam_i) (plus the D1, D2 terms of a continuous model, ``_rate_terms``); quadratic near a
    simple root, so a step below 1e-7 ``scale`` leaves an error of order 1e-14 ``scale``: converged. A request
    leaves the iteration when it has converged (or failed), so slow ones do not cost the others anything.
    """
    return roots_and_vectors(reqs, np.zeros(len(reqs), bool), maxit)[0]


def roots_and_vectors(reqs: list[RootRequest], want: np.ndarray,
                      maxit: int = 30) -> tuple[list[complex | None], list[RootData | None]]:
    """``newton_roots`` and, for the requests flagged in ``want`` [n] whose root was found, (normalized structural
    vector [xi; s xi / omega] [2k], structural content, lag-root flag): ``eigen.struct_vectors``' quantities."""
    m0 = reqs[0].model
    assert all(r.model.coupling == "tustin" and (r.model.lam_a is None) == (m0.lam_a is None) for r in reqs)
    if m0.lam_a is not None and nk.ENABLED:
        return _compiled(reqs, want, maxit)
    k = m0.k
    a = _root_arrays(reqs)
    out: list[complex | None] = [None] * len(reqs)
    act = np.arange(len(reqs))
    with np.errstate(all="ignore"):
        for _ in range(maxit):
            if act.size == 0:
                break
            t, dt = _newton_system(a, act, k)
            try:
                x, sing = np.linalg.solve(t, dt), np.zeros(act.size, bool)
            except np.linalg.LinAlgError:
                x, sing = _solve_each(t, dt)
            tr = np.trace(x, axis1=1, axis2=2)
            ok = np.isfinite(tr) & (tr != 0) & ~sing
            step = np.where(ok, 1.0 / np.where(ok, tr, 1.0), 0.0)
            a["s"][act] -= step
            done = sing | (ok & (np.abs(step) <= 1e-7 * a["scale"][act]))
            for i in act[done].tolist():
                out[i] = complex(a["s"][i])
            act = act[ok & ~done]
        found = np.array([s is not None for s in out], bool)
        return out, _vectors(a, np.nonzero(want & found)[0], k, len(reqs))


RootData = tuple[np.ndarray, float, bool]


def _compiled(reqs: list[RootRequest], want: np.ndarray,
              maxit: int) -> tuple[list[complex | None], list[RootData | None]]:
    """``roots_and_vectors`` of diagonalized models by ``newton_kernel.roots_vectors``, one call per model."""
    out: list[complex | None] = [None] * len(reqs)
    data: list[RootData | None] = [None] * len(reqs)
    groups: dict[int, list[int]] = {}
    for i, r in enumerate(reqs):
        groups.setdefault(id(r.model), []).append(i)
    for idx in groups.values():
        rs = [reqs[i] for i in idx]
        roots, found, xs, cont, lag, good = nk.roots_vectors(
            np.array([r.s0 for r in rs], complex), np.array([r.scale for r in rs], float),
            np.array([r.vc for r in rs], float), np.array([r.q for r in rs], float), want[idx].astype(bool),
            *nk.model_args(rs[0].model), CONTENT_MIN, maxit)
        for j, i in enumerate(idx):
            if found[j]:
                out[i] = complex(roots[j])
                if want[i] and good[j]:
                    data[i] = (xs[j], float(cont[j]), bool(lag[j]))
    return out, data


def _vectors(a: dict[str, np.ndarray], idx: np.ndarray, k: int, n: int) -> list[RootData | None]:
    """Structural vector, content and lag flag at the roots a["s"] of the requests idx (``roots_and_vectors``)."""
    out: list[RootData | None] = [None] * n
    if idx.size == 0:
        return out
    t, dta, dt_rate, on_pole, near = _terms(a, idx, k)
    x, cont = null_vectors(t, a["s"][idx], a["g"][idx], a["omega"][idx], dta, dt_rate)
    x[on_pole] = 0.0
    cont[on_pole] = 0.0
    lag = near & (cont < CONTENT_MIN)
    good = np.isfinite(x).all(axis=1) & np.isfinite(cont)
    for j, i in enumerate(idx.tolist()):
        if good[j]:
            out[i] = (x[j], float(cont[j]), bool(lag[j]))
    return out
