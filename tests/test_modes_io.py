"""External modes from JSON / NPZ: validation, mass normalization, mapping onto the standard mesh."""

import json

import numpy as np
import pytest

from romams_core.mesh import Planform, standard_mesh
from romams_core.modes_io import (
    ExternalModes,
    check_coverage,
    external_modal_result,
    load_modes_json,
    load_modes_npz,
)

PLANFORM = Planform(root_chord=0.4, tip_chord=0.15, semispan=0.55, sweep_le=0.6, n_chord=8, n_span=10)
MESH = standard_mesh(PLANFORM)


def _analytic(xi, eta):
    """Smooth bending / torsion / second-bending-like shapes, [P, 3]."""
    return np.column_stack([eta**2, eta * (xi - 0.4), eta**2 * (1.0 - 2.2 * eta) + 0.3 * eta * xi**2])


def _fe_modes(n_xi=13, n_eta=17, eta_max=1.0, jitter=0.0):
    """FE-like nodes on the planform (a different grid than the standard mesh) with analytic shapes."""
    xi, eta = np.meshgrid(np.linspace(0.0, 1.0, n_xi), np.linspace(0.0, eta_max, n_eta))
    xi, eta = xi.ravel(), eta.ravel()
    if jitter:
        rng = np.random.default_rng(0)
        inner = (xi > 0) & (xi < 1) & (eta > 0) & (eta < eta_max)
        xi = xi + inner * rng.uniform(-jitter, jitter, xi.size)
        eta = eta + inner * rng.uniform(-jitter, jitter, eta.size)
    x, y = PLANFORM.to_xy(xi, eta)
    nodes = np.column_stack([x, y, np.zeros_like(x)])
    return nodes, _analytic(xi, eta)


def _as_json(nodes, shapes, freqs, **extra):
    return {"nodes": nodes.tolist(), "shapes": shapes.T.tolist(), "frequencies_hz": list(freqs), **extra}


def test_json_round_trip_shapes_one_list_per_mode(tmp_path):
    nodes, shapes = _fe_modes()
    path = tmp_path / "modes.json"
    path.write_text(json.dumps(_as_json(nodes, shapes, [20.0, 60.0, 90.0], generalized_masses=[4.0, 0.25, 1.0],
                                        mass_kg=0.24)))
    m = load_modes_json(path)
    np.testing.assert_array_equal(m.shapes, shapes)  # [k][P] in the file -> [P, k]
    np.testing.assert_array_equal(m.nodes, nodes)
    assert m.n_modes == 3 and m.mass_kg == 0.24 and m.source == "modes.json"
    np.testing.assert_allclose(m.mass_normalized_shapes(), shapes / np.array([2.0, 0.5, 1.0]), rtol=1e-15)
    # a parsed dict works the same; [P, k] is accepted too
    m2 = load_modes_json({"nodes": nodes[:, :2].tolist(), "shapes": shapes.tolist(), "frequencies_hz": [1, 2, 3]})
    np.testing.assert_array_equal(m2.shapes, shapes)
    assert m2.generalized_masses is None and m2.mass_kg is None
    np.testing.assert_array_equal(m2.nodes[:, 2], 0.0)


def test_npz_round_trip_and_transposed_shapes(tmp_path):
    nodes, shapes = _fe_modes()
    p1 = tmp_path / "a.npz"
    np.savez(p1, nodes=nodes, shapes=shapes, frequencies_hz=[20.0, 60.0, 90.0], generalized_masses=[1.0, 2.0, 3.0])
    m = load_modes_npz(p1)
    np.testing.assert_array_equal(m.shapes, shapes)
    np.testing.assert_array_equal(m.generalized_masses, [1.0, 2.0, 3.0])
    p2 = tmp_path / "b.npz"
    np.savez(p2, nodes=nodes, shapes=shapes.T, frequencies_hz=[20.0, 60.0, 90.0], mass_kg=0.3)
    m2 = load_modes_npz(p2)
    np.testing.assert_array_equal(m2.shapes, shapes)
    assert m2.mass_kg == pytest.approx(0.3) and m2.generalized_masses is None


def test_mapping_to_standard_mesh_matches_analytic_shapes():
    nodes, shapes = _fe_modes(jitter=0.01)
    gm = np.array([4.0, 0.25, 1.0])
    modes = ExternalModes(nodes=nodes, shapes=shapes * np.sqrt(gm), frequencies_hz=[90.0, 20.0, 60.0],
                          generalized_masses=gm, mass_kg=0.24)
    res = external_modal_result(modes, MESH)
    np.testing.assert_allclose(res.frequencies_hz, [20.0, 60.0, 90.0])  # sorted by frequency
    np.testing.assert_allclose(res.omega, 2 * np.pi * res.frequencies_hz)
    assert res.mass_kg == 0.24 and res.n_fe_nodes == nodes.shape[0]
    xi, eta = PLANFORM.to_xi_eta(MESH.x, MESH.y)
    exact = _analytic(xi, eta)[:, [1, 2, 0]]  # reordered by frequency
    exact *= np.sign(exact[np.argmax(np.abs(exact), axis=0), [0, 1, 2]])  # largest entry positive
    assert res.shapes.shape == (MESH.n_nodes, 3)
    scale = np.abs(exact).max(axis=0)
    # mass normalization undone exactly; C1 interpolation of smooth shapes to < 0.5% of the peak
    assert np.max(np.abs(res.shapes - exact) / scale) < 5e-3
    np.testing.assert_allclose(res.fe_shapes[:, 0] * np.sign(res.fe_shapes[:, 0] @ shapes[:, 1]), shapes[:, 1],
                               atol=1e-12)
    np.testing.assert_allclose(res.fe_xy, nodes[:, :2])


def test_sign_is_deterministic():
    nodes, shapes = _fe_modes()
    a = external_modal_result(ExternalModes(nodes, shapes, [1.0, 2.0, 3.0]), MESH)
    b = external_modal_result(ExternalModes(nodes, -shapes, [1.0, 2.0, 3.0]), MESH)
    np.testing.assert_array_equal(a.shapes, b.shapes)


@pytest.mark.parametrize(
    ("mutate", "match"),
    [
        (lambda d: d.pop("shapes"), "shapes: missing"),
        (lambda d: d.pop("nodes"), "nodes: missing"),
        (lambda d: d.pop("frequencies_hz"), "frequencies_hz: missing"),
        (lambda d: d.update(frequencies_hz=[20.0, -60.0, 90.0]), "frequencies_hz: must all be > 0"),
        (lambda d: d.update(frequencies_hz=[20.0, 60.0]), "shapes: expected 2 modes x"),
        (lambda d: d.update(generalized_masses=[1.0, 1.0]), "generalized_masses: expected 3 values"),
        (lambda d: d.update(generalized_masses=[1.0, 0.0, 1.0]), "generalized_masses: must all be > 0"),
        (lambda d: d.update(mass_kg=-1.0), "mass_kg"),
        (lambda d: d["shapes"][1].__setitem__(4, float("nan")), "shapes: contains NaN"),
        (lambda d: d["nodes"][2].__setitem__(0, "abc"), "nodes: not a numeric array"),
        (lambda d: d.update(nodes=[[0.0, 0.0, 0.0, 1.0]] * len(d["nodes"])), "nodes: expected shape"),
        (lambda d: d.update(shapes=[[0.0] * len(d["nodes"])] * 3), "shapes: modes \\[0, 1, 2\\] are identically zero"),
    ],
)
def test_malformed_json_is_rejected_naming_the_field(mutate, match):
    nodes, shapes = _fe_modes()
    d = _as_json(nodes, shapes, [20.0, 60.0, 90.0])
    mutate(d)
    with pytest.raises(ValueError, match=match):
        load_modes_json(d)


def test_malformed_files(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(ValueError, match="json: bad.json is not valid JSON"):
        load_modes_json(bad)
    lst = tmp_path / "list.json"
    lst.write_text("[1, 2]")
    with pytest.raises(ValueError, match="modes: expected a JSON object, got list"):
        load_modes_json(lst)
    with pytest.raises(ValueError, match="modes: expected a file path or a mapping"):
        load_modes_json([1, 2])  # type: ignore[arg-type]
    nodes, shapes = _fe_modes()
    p = tmp_path / "obj.npz"
    np.savez(p, nodes=nodes, shapes=np.array([shapes, "x"], dtype=object), frequencies_hz=[1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="shapes: cannot be read without pickle"):
        load_modes_npz(p)
    q = tmp_path / "missing.npz"
    np.savez(q, nodes=nodes, shapes=shapes)
    with pytest.raises(ValueError, match="frequencies_hz: missing from missing.npz"):
        load_modes_npz(q)
    r = tmp_path / "junk.npz"
    r.write_bytes(b"not a zip archive")
    with pytest.raises(ValueError, match="npz: junk.npz is not a readable NPZ"):
        load_modes_npz(r)


def test_nodes_that_do_not_cover_the_wing_are_rejected():
    nodes, shapes = _fe_modes(eta_max=0.6)  # FE model covers only 60% of the span
    with pytest.raises(ValueError, match="nodes: the FE nodes do not cover the planform"):
        external_modal_result(ExternalModes(nodes, shapes, [1.0, 2.0, 3.0]), MESH)
    nodes, shapes = _fe_modes()
    with pytest.raises(ValueError, match="nodes: only 0% of the FE nodes lie on the planform"):
        external_modal_result(ExternalModes(nodes * 1000.0, shapes, [1.0, 2.0, 3.0]), MESH)  # millimetres
    swapped = nodes[:, [1, 0, 2]]  # x and y exchanged
    with pytest.raises(ValueError, match="nodes: .*planform"):
        external_modal_result(ExternalModes(swapped, shapes, [1.0, 2.0, 3.0]), MESH)
    tilted = nodes.copy()
    tilted[:, 2] = 0.5 * tilted[:, 1]  # not in the wing plane
    with pytest.raises(ValueError, match="nodes: z spans"):
        external_modal_result(ExternalModes(tilted, shapes, [1.0, 2.0, 3.0]), MESH)
    dup = np.vstack([nodes, nodes[5]])
    with pytest.raises(ValueError, match="nodes: two or more nodes share"):
        check_coverage(dup[:, :2], MESH)
    line = np.column_stack([np.linspace(0.0, 0.3, 20), np.linspace(0.0, 0.55, 20)])
    with pytest.raises(ValueError, match="nodes: "):
        check_coverage(line, MESH)


def test_coverage_accepts_an_irregular_triangulated_fe_model():
    rng = np.random.default_rng(5)
    xi, eta = rng.random(400), rng.random(400)
    edge_xi, edge_eta = np.meshgrid(np.linspace(0, 1, 9), np.linspace(0, 1, 9))
    xi = np.concatenate([xi, edge_xi.ravel()])
    eta = np.concatenate([eta, edge_eta.ravel()])
    x, y = PLANFORM.to_xy(xi, eta)
    check_coverage(np.column_stack([x, y]), MESH)  # no exception


def test_missing_pynastran_gives_a_clear_import_error(monkeypatch):
    import sys

    from romams_core.modes_io import _import_pynastran

    monkeypatch.setitem(sys.modules, "pyNastran.bdf.bdf", None)  # as if pyNastran were not installed
    with pytest.raises(ImportError, match="Nastran BDF/OP2 input needs pyNastran: pip install"):
        _import_pynastran()
