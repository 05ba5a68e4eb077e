"""Typed input errors of the core (romams_core.errors.InputError) and the one Tustin implementation."""

from __future__ import annotations

import pickle
from types import SimpleNamespace

import numpy as np
import pytest

from romams_core.arx import fit_arx
from romams_core.atmosphere import altitude_for_dynamic_pressure, isa
from romams_core.basis import project
from romams_core.errors import InputError
from romams_core.flutter import flutter_analysis, tustin_to_continuous
from romams_core.mesh import Planform
from romams_core.statespace import DiscreteSS, d2c_tustin
from romams_core.validation import check_int, check_number, finite_positive
from romams_core.wing import template

OMEGA = np.array([60.0, 150.0])


def _rom(a=None, b=None):
    na = 3
    return SimpleNamespace(A=0.5 * np.eye(na) if a is None else a, B=np.ones((na, 2)) if b is None else b,
                           C=np.ones((2, na)), D=np.zeros((2, 2)), dt_star=0.1)


def test_input_error_is_a_value_error_with_field_and_reason():
    e = InputError("design.x3", "must be a finite number, got nan")
    assert isinstance(e, ValueError)
    assert (e.field, e.reason, str(e)) == ("design.x3", "must be a finite number, got nan",
                                           "design.x3: must be a finite number, got nan")
    e2 = pickle.loads(pickle.dumps(e))  # worker processes send errors back pickled
    assert (e2.field, e2.reason, str(e2)) == (e.field, e.reason, str(e))
    assert str(InputError("x3", "bad").under("design")) == "design.x3: bad"


@pytest.mark.parametrize(
    ("call", "field"),
    [
        (lambda: flutter_analysis(OMEGA, _rom(a=1.01 * np.eye(3)), 1.0, 0.8), "aero.A"),
        (lambda: flutter_analysis(OMEGA, _rom(b=np.ones((3, 1))), 1.0, 0.8), "aero.B"),
        (lambda: flutter_analysis(OMEGA, SimpleNamespace(A=np.eye(1)), 1.0, 0.8), "aero"),
        (lambda: flutter_analysis(OMEGA, _rom(), 1.0, -0.1), "mach"),
        (lambda: flutter_analysis(OMEGA, _rom(), 1.0, 0.8, sweep="fast"), "sweep"),
        (lambda: flutter_analysis(OMEGA, _rom(), 1.0, 0.0, sweep="constant-speed"), "sweep"),
        (lambda: flutter_analysis(OMEGA, _rom(), 1.0, 0.8, coupling="rk4"), "coupling"),
        (lambda: flutter_analysis(OMEGA, _rom(), 1.0, 0.8, n_points=2), "n_points"),
        (lambda: flutter_analysis(-OMEGA, _rom(), 1.0, 0.8), "omega"),
        (lambda: flutter_analysis(OMEGA, _rom(), 1.0, 0.8, zeta=1.5), "zeta"),
        (lambda: flutter_analysis(OMEGA, _rom(), 0.0, 0.8), "c_ref"),
        (lambda: flutter_analysis(OMEGA, _rom(), 1.0, 0.8, sweep="constant-density", v_max=-1.0), "v_max"),
        (lambda: flutter_analysis(OMEGA, _rom(), 1.0, 0.8, sweep="matched", altitude_range_m=(5e3, 1e3)),
         "altitude_range_m"),
        (lambda: template("cropped-delta").design_vector({**_good_design(), "x3": float("nan")}), "design.x3"),
        (lambda: template("cropped-delta").design_vector({**_good_design(), "x1": 0.9}), "design.x1"),
        (lambda: Planform(-1.0, 0.5, 1.0), "planform.root_chord"),
        (lambda: Planform(1.0, 0.5, 1.0, n_chord=0), "planform.n_chord"),
        (lambda: isa(1e6), "altitude_m"),
        (lambda: altitude_for_dynamic_pressure(1e4, -0.5), "mach"),
        (lambda: project(np.eye(4)[:, :2], np.ones(4), mac_threshold=1.5), "mac_threshold"),
        (lambda: fit_arx(np.zeros((50, 1)), np.zeros((50, 1)), na=-1, nb=2), "na"),
        (lambda: d2c_tustin(DiscreteSS(-np.eye(2), np.ones((2, 1)), np.ones((1, 2)), np.zeros((1, 1)), 0.1)), "ss.A"),
    ],
)
def test_core_checks_raise_input_error_naming_the_field(call, field):
    with pytest.raises(InputError) as exc:
        call()
    assert exc.value.field == field
    assert str(exc.value) == f"{field}: {exc.value.reason}"


def _good_design():
    return {"x1": 0.3, "x2": 0.5, "x3": 0.7, "x4": 0.05, "x5": 1.0, "x6": 1.0, "x7": 0.8}


def test_generic_validators():
    assert check_number("a", 2, 0.0) == 2.0 and check_int("n", np.int64(3), 1, 5) == 3
    assert finite_positive("v", "2.5") == 2.5
    for call in (lambda: check_number("a", True), lambda: check_number("a", 0.0, 0.0),
                 lambda: check_number("a", 1.0, upper=1.0), lambda: check_int("n", 2.0, 1, 5),
                 lambda: finite_positive("v", float("inf"))):
        with pytest.raises(InputError):
            call()


def test_one_tustin_implementation():
    """flutter.tustin_to_continuous and statespace.d2c_tustin are the same map (same operations, same numbers)."""
    rng = np.random.default_rng(0)
    q, _ = np.linalg.qr(rng.standard_normal((5, 5)))
    ss = DiscreteSS(0.9 * q, rng.standard_normal((5, 2)), rng.standard_normal((2, 5)), rng.standard_normal((2, 2)),
                    0.05)
    ct = d2c_tustin(ss)
    for x, y in zip(tustin_to_continuous(ss.A, ss.B, ss.C, ss.D, ss.dt_star), (ct.A, ct.B, ct.C, ct.D), strict=True):
        np.testing.assert_array_equal(x, y)
