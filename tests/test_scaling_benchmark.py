"""benchmarks.scaling on a small case: every sweep is filled, bases have exactly the asked size, and the cost of a
structure grows with the number of Machs (the in-process part; fast RFA settings, one basis size)."""

from __future__ import annotations

import json

import pytest

from benchmarks import run as bench
from benchmarks import scaling
from romams.services.training import rom_identity


@pytest.fixture(scope="module")
def result() -> dict:
    """The in-process sweeps with k = 4, m = 5 and 8 LHS samples (DLM, 4 reduced frequencies, one lag)."""
    mp = pytest.MonkeyPatch()
    mp.setattr(bench, "_ident", lambda: rom_identity("dlm", options={"k_values": [0.0, 0.1, 0.3, 0.6],
                                                                          "n_lags": 1}))
    try:
        yield scaling.in_process(True, bench.eig_calibration_ms(), modes=(4,), bases=(5,), samples=8)
    finally:
        mp.undo()


def test_sweeps_are_filled_with_ratios(result: dict) -> None:
    json.loads(json.dumps(result))
    (by_basis,), (by_modes,), (train,) = (result["structure_by_basis"], result["structure_by_modes"],
                                          result["training_by_basis"])
    assert by_basis["n_basis"] == 5 and by_modes["modes"] == 4 and train["n_basis"] == 5
    assert train["train_s_per_mach"] > 0 and train["train_over_eig"] > 0
    for row in (by_basis, by_modes, *result["structure_by_machs"]):
        assert row["alone_ms"] > 0 and row["batched_ms"] > 0
        assert row["alone_over_eig"] > 1 and row["batched_over_eig"] > 1
        assert row["eigen_solves_per_mach"] >= 1


def test_cost_grows_with_the_number_of_machs(result: dict) -> None:
    """1, 5, 10 Machs: the flutter part (the structure's cost less its modal analysis, which does not depend on the
    Machs and is most of a one-Mach structure since the compiled continuation) costs more than twice as much at 10
    Machs as at one."""
    one, five, ten = result["structure_by_machs"]
    assert (one["machs"], five["machs"], ten["machs"]) == (1, 5, 10)
    assert ten["alone_ms"] - ten["alone_modal_ms"] > 2 * (one["alone_ms"] - one["alone_modal_ms"])
    assert ten["batched_ms"] - ten["batched_modal_ms"] > 2 * (one["batched_ms"] - one["batched_modal_ms"])
