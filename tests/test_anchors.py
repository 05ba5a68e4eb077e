"""Harmonic anchors: the tone analysis against closed-form transfer functions, and the lag correction."""

from dataclasses import dataclass

import numpy as np
import pytest
from test_statespace import _system

from romams_core.anchors import (
    anchor_lags,
    anchored,
    check_anchor_k,
    harmonic_anchors,
    step_anchors,
    step_records,
    step_transfer,
    tone_amplitudes,
)
from romams_core.errors import InputError
from romams_core.statespace import ContinuousSS, DiscreteSS


@dataclass
class LtiSolver:
    """A linear time-invariant system in t* as a time-domain solver: its exact transfer matrix is ``ss.freqresp``."""

    ss: DiscreteSS
    name: str = "lti"

    def simulate(self, mesh, shapes, signals, mach, dt_star, progress=None):  # noqa: ANN001, ANN201
        assert dt_star == self.ss.dt_star
        return self.ss.simulate(signals)


@dataclass
class _Mesh:
    c_ref: float = 0.5


def test_tone_amplitudes_are_exact_for_a_sum_of_sinusoids():
    """Two tones plus an offset on a window that is not a whole number of samples per period: exact to 1e-12."""
    t = np.arange(0.0, 40.0, 0.1)
    x = 3.0 + 2.0 * np.cos(0.3 * t + 0.4) + 0.5 * np.cos(0.6 * t - 1.1)
    c = tone_amplitudes(x, t, np.array([0.3, 0.6]))
    np.testing.assert_allclose(c, [2.0 * np.exp(0.4j), 0.5 * np.exp(-1.1j)], atol=1e-12)


def test_harmonic_anchors_recover_the_transfer_matrix_of_a_linear_system():
    """One two-tone run per input of a stable 12-state, 3-input system: every column at k 0.05 and 0.1 within 1e-3
    of the closed-form transfer matrix (the ramp's transient is what is left)."""
    ss = _system(3)
    k = np.array([0.05, 0.1])
    shapes = np.eye(3)
    gaf = harmonic_anchors(LtiSolver(ss), _Mesh(), shapes, 0.5, k, dt_star=ss.dt_star)
    ref = ss.freqresp(k)
    assert np.abs(gaf - ref).max() < 1e-3 * np.abs(ref).max()


def test_step_anchors_give_the_transfer_matrix_at_every_low_k():
    """One step record per input of the same 12-state, 3-input system, held 120 t*: the transfer matrix at k 0 (the
    settled gain), 0.01, 0.025, 0.05 and 0.1 within 1e-6 of the closed form, a record cut at 5 t* (before the slow
    poles have settled) is over 1000x further off: the hold is what makes it exact."""
    ss = _system(3)
    k = np.array([0.0, 0.01, 0.025, 0.05, 0.1])
    ref = ss.freqresp(k)
    gaf = step_anchors(LtiSolver(ss), _Mesh(), np.eye(3), 0.5, k, dt_star=ss.dt_star)
    assert gaf.shape == (5, ss.n_outputs, 3)
    assert np.abs(gaf - ref).max() < 1e-6 * np.abs(ref).max()
    rec = step_records(np.eye(3), 0.5, hold=120.0, dt_star=ss.dt_star)
    assert len(rec) == 3 and rec[1].shape == (1201, 3) and np.all(rec[1][:, [0, 2]] == 0.0)
    assert rec[1][-1, 1] == pytest.approx(0.002 * 0.5) and rec[1][0, 1] == 0.0
    y = ss.simulate(rec[0])[:51]
    cut = np.abs(step_transfer(y, rec[0][:51, 0], k, ss.dt_star) - ref[:, :, 0]).max()
    assert cut > 1e3 * np.abs(gaf[:, :, 0] - ref[:, :, 0]).max() and cut > 1e-5 * np.abs(ref).max()
    with pytest.raises(InputError, match="anchor_hold"):
        step_records(np.eye(3), 0.5, hold=5.0)


def test_step_anchors_of_chosen_columns_are_those_columns_of_the_whole_matrix():
    """``columns`` runs only those shapes' records: the same columns as the whole matrix to 1e-12, in the order
    asked; an index outside the shapes is refused naming ``columns``."""
    ss = _system(3)
    k = np.array([0.0, 0.05, 0.3])
    whole = step_anchors(LtiSolver(ss), _Mesh(), np.eye(3), 0.5, k, dt_star=ss.dt_star)
    part = step_anchors(LtiSolver(ss), _Mesh(), np.eye(3), 0.5, k, dt_star=ss.dt_star, columns=[2, 0])
    assert part.shape == (3, ss.n_outputs, 2)
    np.testing.assert_allclose(part, whole[:, :, [2, 0]], rtol=0.0, atol=1e-12 * np.abs(whole).max())
    for bad in ([3], [], [-1]):
        with pytest.raises(InputError, match="columns"):
            step_anchors(LtiSolver(ss), _Mesh(), np.eye(3), 0.5, k, dt_star=ss.dt_star, columns=bad)


def test_anchored_model_meets_the_anchors_and_stays_close_elsewhere():
    """A model with poles 1 % off, anchored to the true system at k 0.05 / 0.1: the anchors to 1e-10; the
    correction is bounded over k 0-1.5 by a few times the anchors' residual; stable; no-op when already met."""
    true = _system(5, n=16, m=2)
    off = DiscreteSS(A=0.99 * true.A, B=true.B, C=true.C, D=true.D, dt_star=0.1)
    k = np.array([0.05, 0.1])
    ref = true.freqresp(k)
    fixed = anchored(off, k, ref)
    np.testing.assert_allclose(fixed.freqresp(k), ref, atol=1e-10 * np.abs(ref).max())
    assert fixed.n_states == off.n_states + 3 * 2 and fixed.is_stable()
    k_all = np.linspace(0.0, 1.5, 61)
    change = np.abs(fixed.freqresp(k_all) - off.freqresp(k_all)).max()
    residual = np.abs(ref - off.freqresp(k)).max()
    assert 0.0 < change < 5.0 * residual
    np.testing.assert_allclose(fixed.freqresp(k_all[:1]), off.freqresp(k_all[:1]) + (fixed.D - off.D)
                               + fixed.C[:, off.n_states:] @ np.linalg.solve(
                                   np.eye(6) - fixed.A[off.n_states:, off.n_states:], fixed.B[off.n_states:]))
    same = anchored(off, k, off.freqresp(k))
    np.testing.assert_allclose(same.freqresp(k_all), off.freqresp(k_all), atol=1e-12 * np.abs(ref).max())


def test_anchored_continuous_model_keeps_its_form_and_meets_the_anchors():
    """An RFA-type continuous model (D1 term) anchored at k 0.05 / 0.1 / 0.3: exact there to 1e-12, still
    continuous with D1 kept, stable (lag poles -2 beta), and unchanged at k = 0 but for E_0."""
    rng = np.random.default_rng(3)
    ss = ContinuousSS(A=-np.diag([0.2, 0.5, 1.0]), B=rng.standard_normal((3, 2)), C=rng.standard_normal((2, 3)),
                      D=rng.standard_normal((2, 2)), D1=0.1 * np.eye(2))
    k = np.array([0.05, 0.1, 0.3])
    target = ss.freqresp(k) + 0.05 * (rng.standard_normal((3, 2, 2)) + 1j * rng.standard_normal((3, 2, 2)))
    fixed = anchored(ss, k, target)
    assert isinstance(fixed, ContinuousSS) and fixed.D1 is ss.D1 and fixed.is_stable()
    assert fixed.n_states == ss.n_states + 5 * 2
    np.testing.assert_allclose(fixed.freqresp(k), target, atol=1e-12 * np.abs(target).max())


def test_anchor_lags_and_bad_anchors():
    """2 K - 1 lag poles spanning the anchors; anchor_k and anchor_gaf refused with the field named."""
    np.testing.assert_allclose(anchor_lags(np.array([0.05, 0.1])), [0.05, 0.1, 0.2])
    assert anchor_lags(np.array([0.06])).size == 1
    for bad in ([], [0.0], [0.05, 0.05], [2.0], [np.nan], [0.1] * 5, "x", [[0.1], [0.2]]):
        with pytest.raises(InputError, match="anchor_k"):
            check_anchor_k(bad, 1.5)
    np.testing.assert_array_equal(check_anchor_k([0.1, 0.05], 1.5), [0.05, 0.1])
    with pytest.raises(InputError, match="anchor_gaf"):
        anchored(_system(1), np.array([0.05]), np.zeros((1, 3, 2)))
