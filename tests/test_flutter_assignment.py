"""The compiled tracking step (``flutter.assignment``) against the numpy/scipy step it replaces.

- ``lsap`` against ``scipy.optimize.linear_sum_assignment`` on random rectangular costs, and on integer costs full
  of ties: the same total cost always, and the same columns (both implement the shortest augmenting path method
  with the same tie rule).
- ``tracking.assign`` against ``tracking.assign_numpy`` on every step of real flutter searches (30 random
  structures x 5 Machs on random discrete ROMs, the batch test's designs, and other sweeps and couplings at one
  Mach): the same assignment, the branch eigenvalues within 1e-12 relative and the step checks within 1e-12. One
  exception is allowed, where the choice is a rounding-level tie by symmetry: a real root's branch may continue
  on either member of a conjugate pair (their costs agree to 1e-15, so the last bit of the MAC sum decides, in
  numpy as in the kernel; BLAS sums in another order on another machine). Then the two choices must be each
  other's conjugates.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment
from test_flutter_batch import FLUTTER_OPTIONS, designs  # noqa: F401 - the fixture

from romams_core.evaluate import evaluate_structures
from romams_core.flutter import flutter_batch, tracking
from romams_core.flutter.assignment import lsap
from romams_core.statespace import to_modal


@pytest.mark.parametrize("shape", [(1, 1), (1, 5), (3, 3), (4, 9), (4, 40), (8, 30), (12, 80)])
def test_lsap_equals_scipy_on_random_costs(shape):
    rng = np.random.default_rng(sum(shape))
    for _ in range(200):
        cost = rng.uniform(0.0, 2.0, shape) * (rng.uniform(size=shape) < 0.9) + 10.0 * (rng.uniform(size=shape) < 0.1)
        rows, ref = linear_sum_assignment(cost)
        got = lsap(cost)
        assert cost[rows, got].sum() == pytest.approx(cost[rows, ref].sum(), rel=1e-13, abs=1e-13)
        np.testing.assert_array_equal(got, ref)


def test_lsap_equals_scipy_on_ties():
    """Integer costs in {0, 1, 2}: many optimal assignments; the kernel picks scipy's."""
    rng = np.random.default_rng(3)
    for shape in ((4, 4), (4, 12), (6, 20)):
        for _ in range(300):
            cost = rng.integers(0, 3, shape).astype(float)
            _, ref = linear_sum_assignment(cost)
            np.testing.assert_array_equal(lsap(cost), ref)


def test_compiled_step_equals_numpy_step_on_real_searches(designs, monkeypatch):  # noqa: F811
    basis, modals, roms = designs
    calls = {"n": 0, "lag": 0, "content": 0, "swap": 0}
    fast = tracking.assign

    def both(prev, e, weight, omega):
        new, check = fast(prev, e, weight, omega)
        ref, ref_check = tracking.assign_numpy(prev, e, weight, omega)
        tol = 1e-12 * np.max(omega)
        swap = np.abs(new.lam - ref.lam) > tol
        if swap.any():  # a real root's branch on the other member of a conjugate pair
            assert np.all(np.abs(prev.lam[swap].imag) <= tol), (prev.lam, new.lam, ref.lam)
            np.testing.assert_allclose(new.lam[swap], ref.lam[swap].conj(), rtol=1e-12, atol=tol)
            np.testing.assert_allclose(new.vec[:, swap], ref.vec[:, swap].conj(), rtol=1e-12, atol=1e-12)
            calls["swap"] += 1
            ref.lam[swap], ref.vec[:, swap] = new.lam[swap], new.vec[:, swap]
        np.testing.assert_allclose(new.lam, ref.lam, rtol=1e-12, atol=tol)
        np.testing.assert_array_equal(new.vec, ref.vec)  # the same columns of the same candidates
        assert new.lag == ref.lag and check.lag == ref_check.lag
        for f in ("mac_min", "jump", "gap"):
            assert getattr(check, f) == pytest.approx(getattr(ref_check, f), rel=1e-12, abs=1e-12), f
        if new.content is not None:
            np.testing.assert_array_equal(new.content, ref.content)
            calls["content"] += 1
        calls["n"] += 1
        calls["lag"] += int(check.lag)
        return new, check

    monkeypatch.setattr(tracking, "assign", both)
    eigen = {"tracking": "eigen"}  # the tracker that assigns every step (the default continues most by Newton)
    evaluate_structures(modals, basis, roms, zeta=0.01, flutter_options={**FLUTTER_OPTIONS, **eigen})
    rom, c_ref = roms[0.87]
    pairs = [(m.omega, to_modal(rom, np.linalg.lstsq(basis, m.shapes, rcond=None)[0])) for m in modals[:10]]
    for kw in ({"sweep": "constant-density", "zeta": 0.01, **FLUTTER_OPTIONS, **eigen},
               {"sweep": "matched", "zeta": None, **eigen},
               {"sweep": "constant-speed", "zeta": 0.01, "coupling": "zoh", **FLUTTER_OPTIONS}):  # alias unwrap
        flutter_batch(pairs, c_ref, 0.87, **kw)
    assert calls["n"] > 5000 and calls["content"] == calls["n"] and calls["swap"] <= 0.01 * calls["n"], calls


def _may_cross_numpy(p, g):
    """The numpy hump test the kernel replaced (tracking._may_cross before it was compiled)."""
    p0, p1, p2 = p
    if np.any(g[2] > tracking.G_UNSTABLE):
        return False
    d01 = (g[1] - g[0]) / (p1 - p0)
    d12 = (g[2] - g[1]) / (p2 - p1)
    err = np.abs(g[2] - (g[1] + d01 * (p2 - p1)))
    c2 = (d12 - d01) / (p2 - p0)
    with np.errstate(divide="ignore", invalid="ignore"):
        pv = 0.5 * (p1 + p2) - 0.5 * d12 / c2
        gv = g[1] + (pv - p1) * (d12 + c2 * (pv - p2))
    top = np.maximum(g[1], g[2])
    top = np.where((c2 < 0) & (pv > p1) & (pv < p2), np.maximum(top, gv), top)
    return bool(np.any(top + tracking.HUMP_ERR * err > tracking.HUMP_FLOOR))


def _smooth_or_hump_numpy(sm, s0, s1, xm, x0, x1, omega, hump):
    """The numpy smoothness and hump checks of Tracker._split before they were compiled."""
    pred = s0 + (s0 - sm) * ((x1 - x0) / (x0 - xm))
    if np.max(np.abs(s1 - pred) / np.maximum(np.abs(s0), omega)) > tracking.SMOOTH_TOL:
        return True
    if not hump:
        return False
    g = np.array([2.0 * s.real / np.abs(s) for s in (sm, s0, s1)])
    return _may_cross_numpy((xm, x0, x1), g)


@pytest.mark.filterwarnings("ignore:divide by zero:RuntimeWarning", "ignore:invalid value:RuntimeWarning")
def test_refinement_checks_equal_their_numpy_form():
    """Hump test, smoothness test and content jump on 5,000 random steps, many near their thresholds (damping
    near 0, a parabola vertex inside the step, roots near the extrapolation limit, NaN content)."""
    rng = np.random.default_rng(11)
    omega = np.array([50.0, 120.0, 300.0, 420.0])
    hits = np.zeros(3, int)
    for _ in range(5000):
        x = np.sort(rng.uniform(0.0, 1.0, 3))
        if rng.uniform() < 0.05:
            x[1] = x[0]  # a zero-length history step: inf and NaN handled as numpy does
        g = rng.choice([1e-3, 1e-6, 1e-8])[()] * rng.standard_normal((3, 4)) - rng.uniform(0, 2e-6, (3, 4))
        hump = tracking._may_cross(tuple(x), g)
        assert hump == _may_cross_numpy(tuple(x), g), (x, g)
        s0 = omega * (rng.uniform(-0.05, 0.01, 4) + 1j * rng.uniform(0.5, 1.5, 4))
        sm = s0 * (1 + 0.2 * rng.standard_normal(4))
        s1 = s0 + (s0 - sm) * ((x[2] - x[1]) / (x[1] - x[0]) if x[1] > x[0] else 1.0) \
            + 0.3 * np.abs(s0) * rng.standard_normal(4) * rng.uniform()
        flag = bool(rng.uniform() < 0.7)
        got = tracking.not_smooth_or_hump(sm, s0, s1, *x, omega, flag,
                                          np.array([tracking.SMOOTH_TOL, *tracking._hump_consts()]))
        assert got == _smooth_or_hump_numpy(sm, s0, s1, *x, omega, flag)
        c0 = rng.uniform(0, 1, 4)
        c1 = c0 + 0.06 * rng.standard_normal(4)
        c1[rng.uniform(size=4) < 0.1] = np.nan
        a, b = tracking.Branches(s0, np.eye(8, 4), content=c0), tracking.Branches(s1, np.eye(8, 4), content=c1)
        away = (np.abs(s0) > tracking.CONTENT_AWAY * omega) & (np.abs(s1) > tracking.CONTENT_AWAY * omega)
        with np.errstate(invalid="ignore"):
            ref = bool(np.any(away & (np.abs(c1 - c0) > tracking.CONTENT_JUMP)))
        assert tracking._content_jump(a, b, omega) == ref
        hits += [hump, got, ref]
    assert np.all(hits > 250) and np.all(hits < 4750), hits  # both outcomes well represented
