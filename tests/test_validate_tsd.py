"""The job plumbing of benchmarks.validate_tsd: ARX orders ride in a job's options, and a point whose training
fails becomes a row with the error (the other points still run)."""

from __future__ import annotations

import numpy as np
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


def test_direct_table_flutter_point_matches_the_rom_route_on_the_dlm() -> None:
    """``benchmarks.agard_direct_flutter.flutter_point`` (matched-Mach p-k on a harmonic table) on the DLM's table of
    AGARD 445.6's modes at M 0.96 gives the DLM ROM's matched-Mach point of ``validate_tsd`` within 0.5 % in speed
    and 1 % in frequency; both are the DLM's known over-prediction there (+6 to +8 % against the 310.96 m/s
    experiment, docs/transonic.md 7.1)."""
    import math

    import numpy as np

    from benchmarks.agard_direct_flutter import _wing, flutter_point
    from romams.services.training import train
    from romams_core.aero.dlm import frequency_response
    from romams_core.flutter import flutter_analysis

    wing, mesh, modal = _wing()
    k = np.arange(0.0, 0.61, 0.04)  # the modes reach k 0.52 at V_exp; the table's interpolation costs < 0.01 %
    direct = flutter_point(frequency_response(mesh, modal.shapes, 0.96, k), k, modal.omega, mesh.c_ref, 0.96)
    rom = train(mesh, modal.shapes, 0.96, vt.rom_identity("dlm", wing=wing))
    rho, v_exp, _ = vt.AGARD_EXPERIMENT[0.96]
    r = flutter_analysis(modal.omega, rom.ss, rom.c_ref, 0.96, sweep="constant-speed", rho_ref=rho, a_ref=v_exp / 0.96)
    v_rom = math.sqrt(2.0 * r.q_flutter_pa / rho)
    assert direct["v_f"] == pytest.approx(v_rom, rel=5e-3)
    assert direct["omega_f"] == pytest.approx(r.omega_flutter_rad_s, rel=1e-2)
    assert 6.0 < direct["v_error_pct"] < 8.0 and not direct["table_held"]
    # a table that ends below the torsion mode's k at zero density (0.52): the sweep holds its last value beyond it
    # and finds the same bending-torsion point, at k near 0.08
    short = k[k < 0.45]
    held = flutter_point(frequency_response(mesh, modal.shapes, 0.96, short), short, modal.omega, mesh.c_ref, 0.96)
    assert held["table_held"] and held["v_f"] == pytest.approx(direct["v_f"], rel=2e-3)


def test_direct_study_grids_and_table_change() -> None:
    """``agard_direct_flutter.Case`` refines only the named axes (z: the first height too), every axis as
    ``tsd_grid_spec``, sets GridSpec fields before the scaling and names its cache files by what differs from the
    defaults; ``table_change`` is the largest entry difference in % of the reference's largest entry."""
    import numpy as np

    from benchmarks.agard_direct_flutter import K_TABLE, Case, table_change
    from romams_core.aero.tsd.grid import GridSpec
    from romams_core.training_tsd import tsd_grid_spec

    base = GridSpec()
    y = Case().spec().scaled(2.0, "y")
    assert (y.n_span, y.n_outboard) == (36, 20) and (y.n_chord, y.n_z, y.dz0) == (base.n_chord, base.n_z, base.dz0)
    z = Case().spec().scaled(1.5, "z")
    assert z.n_z == 33 and z.dz0 == pytest.approx(base.dz0 / 1.5) and z.n_span == base.n_span
    assert Case().spec().scaled(1.25) == tsd_grid_spec(1.25) and Case().tag() == ""
    wide = Case(span_cluster=0.0, grid=(("y_outboard", 5.0), ("n_outboard", 20)), cross_upwind=False)
    spec = wide.spec().scaled(2.0, "y")
    assert (spec.span_cluster, spec.y_outboard, spec.n_outboard, spec.n_span) == (0.0, 5.0, 40, 36)
    assert isinstance(spec.n_outboard, int) and wide.tag() == "-sc0-y_outboard5-n_outboard20-central"
    ref = np.ones((K_TABLE.size, 4, 4), dtype=complex)
    other = ref.copy()
    other[:, 1, 2] += 0.03j
    assert table_change(ref, other, 0.08) == pytest.approx(3.0)


def test_linear_direct_extrapolation_and_worst_entry() -> None:
    from benchmarks import tsd_linear_direct as tld

    rng = np.random.default_rng(3)
    exact = rng.normal(size=(tld.LINEAR_K.size, 4, 4)) + 1j * rng.normal(size=(tld.LINEAR_K.size, 4, 4))
    c = rng.normal(size=exact.shape)
    coarse, fine = exact + c * 1.0 ** 1.5, exact + c * (1.0 / 1.5) ** 1.5  # error ~ h^1.5, cells x 1.5
    np.testing.assert_allclose(tld.richardson(coarse, fine, 1.5, 1.5), exact, rtol=0, atol=1e-12)
    ref = np.tile(np.diag([10.0, 8.0, 6.0, 4.0]) + 0.01, (tld.LINEAR_K.size, 1, 1)).astype(complex)
    ref[:, 1, 2] = 2.0  # a large off-diagonal entry (a fifth of the largest)
    h = ref.copy()
    h[7, 1, 2] *= 1.12  # 12 % off at the eighth k
    h[:, 0, 3] = 0.5  # a small entry (below a tenth of the largest) far off: not counted as large
    s = tld.summary(h, ref)
    assert s["large_entries"]["magnitude_pct"] == pytest.approx(12.0, abs=1e-9)
    assert s["diagonal"]["magnitude_pct"] == pytest.approx(0.0, abs=1e-12)
    assert s["worst_large_entry"] == {"row": 1, "col": 2, "k": pytest.approx(tld.LINEAR_K[7])}


def test_linear_direct_column_summary_names_every_entry_of_the_columns() -> None:
    from benchmarks import tsd_linear_direct as tld

    nk = tld.LINEAR_K.size
    ref = np.full((nk, 4, 2), 2.0 + 1.0j)
    h = ref.copy()
    h[5, 3, 0] *= 0.9 * np.exp(1j * np.radians(4.0))  # entry (4, 3) 10 % low and 4 deg ahead at the sixth k
    s = tld.column_summary(h, ref, [2, 1])
    assert set(s) == {f"({i},{j})" for i in range(1, 5) for j in (3, 2)}
    assert s["(4,3)"]["magnitude_pct"] == pytest.approx(10.0, abs=1e-9)
    assert s["(4,3)"]["phase_deg"] == pytest.approx(4.0, abs=1e-9)
    assert s["(4,3)"]["ratio"][5] == pytest.approx(0.9, abs=1e-12) and s["(4,3)"]["ratio"][4] == 1.0
    assert s["(4,2)"]["magnitude_pct"] == 0.0 and s["(1,3)"]["phase_deg"] == 0.0


def test_linear_direct_grid_fields_are_set_before_the_scaling() -> None:
    """``--grid y_outboard=5 n_outboard=15`` on the grid x 2: 30 outboard cells (the field scaled with the rest),
    the extent kept; no fields: the training's grid of that scale."""
    from benchmarks import tsd_linear_direct as tld
    from romams_core.training_tsd import tsd_grid_spec

    g = tld.grid_spec(2.0, {"y_outboard": 5.0, "n_outboard": 15})
    assert (g.n_outboard, g.y_outboard, g.n_span, g.n_z) == (30, 5.0, 36, 44)
    assert tld.grid_spec(1.5) == tsd_grid_spec(1.5) and tld.grid_spec(1.0, {}) == tsd_grid_spec(1.0)


def test_linear_direct_observed_order() -> None:
    from benchmarks import tsd_linear_direct as tld

    base, c = np.ones((3, 2, 2)), np.arange(12.0).reshape(3, 2, 2) + 1.0
    scales = [1.0, 1.5, 2.0]
    tables = [base + c * (1.0 / s) ** 1.4 for s in scales]
    assert tld.observed_order(tables, scales) == pytest.approx(1.4, abs=1e-8)
    assert tld.observed_order(tables[:2], scales[:2]) is None
