"""The evaluation use case's fit flag: estimated error and the modes named in the warning."""

from types import SimpleNamespace

import numpy as np
import pytest

from romams.services.evaluation import Models, fit_error_estimate, summarize


def _result(mac):
    env = SimpleNamespace(mach=np.zeros(0), safe_altitude_m=np.zeros(0), status=[])
    return SimpleNamespace(envelope=env, comparison=None, mass_kg=0.24, min_mac=float(min(mac)), mac_ok=True,
                           mac=np.asarray(mac), flutter=[], frequencies_hz=np.array([10.0, 20.0, 30.0]),
                           sdoff=False, constraints_ok=True, message="ok")


def _models(threshold):
    basis = SimpleNamespace(n_basis=5, mac_threshold=threshold)
    return Models(1, SimpleNamespace(name="w", modal_damping=0.0), None, 1, basis, {})


def test_fit_error_estimate_is_first_order_in_the_residual():
    # 0.30 sqrt(1 - MAC): 4.2 % at MAC 0.98, 0.3 % at MAC 0.9999 (calibration points 4.5 % and 0.63 % at 0.9995)
    assert fit_error_estimate(0.98) == pytest.approx(0.30 * np.sqrt(0.02), rel=1e-12)
    assert fit_error_estimate(0.9999) == pytest.approx(0.003, rel=1e-9)
    assert fit_error_estimate(1.0) == 0.0


def test_warning_names_the_modes_beyond_the_validated_accuracy():
    # a basis built with MAC 0.98: mode 2 passes its threshold but its estimated error (3.7 %) exceeds the 1 %
    out = summarize(_result([0.99999, 0.985, 0.9999]), _models(0.98))
    assert out["mac_ok"] is True and out["fit_error_estimate_pct"] == pytest.approx(100 * 0.30 * np.sqrt(0.015))
    assert out["warning"].startswith("modes [2] fit the basis with MAC < 0.998889")
    # the default basis: within its validated accuracy, no warning
    assert summarize(_result([0.99999, 0.99995, 0.99992]), _models(0.9999))["warning"] is None


def test_the_evaluation_key_changes_with_the_evaluation_version(monkeypatch):
    """Results cached before a change of how stored models are evaluated (EVALUATION_VERSION) are not served again:
    the same inputs give another key under another version, and the same key under the same one."""
    from romams.services import evaluation as ev

    args = (1, 2, [3, 4], {"sweep": "constant-speed"}, [0.5, 0.25])
    key = ev.evaluation_key(*args)
    assert ev.evaluation_key(*args) == key
    monkeypatch.setattr(ev, "EVALUATION_VERSION", ev.EVALUATION_VERSION - 1)
    assert ev.evaluation_key(*args) != key
