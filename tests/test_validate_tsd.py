"""The job plumbing of benchmarks.validate_tsd: ARX orders ride in a job's options, and a point whose training
fails becomes a row with the error (the other points still run)."""

from __future__ import annotations

import pytest

import benchmarks.validate_tsd as vt
from romams_core.training import TrainingError
from romams_core.wing import template


def test_orders_in_the_options_go_to_the_identity_not_the_solver_settings() -> None:
    wing = template("agard-445.6")
    ident = vt._identity("tsd", {"na": 14, "nb": 12, "grid_scale": 0.5}, wing)
    assert (ident["na"], ident["nb"]) == (14, 12)
    assert ident["options"]["grid_scale"] == 0.5 and "na" not in ident["options"] and "nb" not in ident["options"]
    default = vt._identity("tsd", {}, wing)
    assert (default["na"], default["nb"]) == (vt.rom_identity("tsd")["na"], vt.rom_identity("tsd")["nb"])


@pytest.mark.parametrize("point, args", [(vt._agard_point, (0.499, "tsd", {"na": 6, "nb": 6})),
                                         (vt._cropped_point, (0.87, "tsd", {"na": 6, "nb": 6}))])
def test_a_failed_training_becomes_a_row(monkeypatch, point, args) -> None:  # noqa: ANN001
    seen = []

    def failing(mesh, shapes, mach, ident):  # noqa: ANN001, ANN202
        seen.append(ident)
        raise TrainingError("validation NRMSE above nrmse_tol")

    monkeypatch.setattr(vt, "train", failing)
    row = point(args)
    assert row == {"args": list(args), "error": "validation NRMSE above nrmse_tol"}
    assert (seen[0]["na"], seen[0]["nb"]) == (6, 6)
