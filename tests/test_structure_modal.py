"""Modal analysis of the templates: cropped delta calibration, Goland, design effects, normalization, mapping."""

import dataclasses
import math

import numpy as np
import pytest

from romams_core.mesh import Planform, standard_mesh
from romams_core.structure.mapping import map_to_mesh
from romams_core.structure.modal import build_model, modal_analysis, solve_modes
from romams_core.wing import template

DESIGN = {"x1": 0.25, "x2": 0.6, "x3": 0.8, "x4": 0.05, "x5": 1.5, "x6": 1.2, "x7": 0.8}


@pytest.fixture(scope="module")
def delta():
    return template("cropped-delta")


@pytest.fixture(scope="module")
def baseline(delta):
    return modal_analysis(delta, None, n_modes=4)


def test_cropped_delta_baseline_matches_measured_frequencies_and_mass(baseline, delta):
    np.testing.assert_allclose(baseline.frequencies_hz[:3], [26.7, 88.2, 131.8], rtol=0.03)
    assert math.isclose(baseline.mass_kg, 0.24, rel_tol=0.02)
    n = standard_mesh(delta.planform).n_nodes
    assert baseline.shapes.shape == (n, 4)
    assert baseline.fe_shapes.shape == (baseline.n_fe_nodes, 4) and baseline.fe_xy.shape == (baseline.n_fe_nodes, 2)
    np.testing.assert_allclose(baseline.omega, 2 * np.pi * baseline.frequencies_hz, rtol=1e-14)


def test_modes_are_mass_normalized_and_k_orthogonal(delta):
    model = build_model(delta, DESIGN)
    omega, phi = solve_modes(model, 4)
    np.testing.assert_allclose(phi.T @ (model.M @ phi), np.eye(4), atol=1e-8)
    np.testing.assert_allclose(phi.T @ (model.K @ phi), np.diag(omega**2), rtol=1e-8, atol=1e-8 * omega[-1] ** 2)


def test_translation_mass_equals_total_mass_and_rigid_motion_is_strain_free(delta):
    model = build_model(delta, DESIGN)
    n, s = model.xy.shape[0], model.dofs_per_node  # 3 (bending) or 6 (flat shell: + u, v, theta_z)
    u = np.zeros(s * n)
    u[0::s] = 1.0
    assert math.isclose(u @ (model.M @ u), model.mass_kg, rel_tol=1e-10)
    u[0::s] = 0.2 + 0.5 * model.xy[:, 0] - 0.3 * model.xy[:, 1]  # w = a + b x + c y
    u[1::s], u[2::s] = 0.5, -0.3
    assert np.max(np.abs(model.K @ u)) < 1e-9 * abs(model.K).max()


def test_total_mass_is_plate_plus_beam_plus_lumped_mass(delta, baseline):
    r = modal_analysis(delta, DESIGN)
    s = delta.structure_for(DESIGN)
    pf = delta.planform
    length = math.dist((s.beam.root_position * pf.root_chord, 0.0), pf.to_xy(s.beam.tip_position, 1.0))
    beam_mass = 2700.0 * s.beam.height * s.beam.width * length
    assert math.isclose(r.mass_kg, 0.8 * baseline.mass_kg + 0.05 + beam_mass, rel_tol=1e-9)


def test_lumped_mass_lowers_first_frequency_and_moves_with_position(delta):
    light = modal_analysis(delta, {**DESIGN, "x4": 0.0})
    heavy = modal_analysis(delta, {**DESIGN, "x4": 0.1})
    assert np.all(heavy.frequencies_hz[:2] < light.frequencies_hz[:2])
    assert math.isclose(heavy.mass_kg - light.mass_kg, 0.1, rel_tol=1e-9)
    inboard = modal_analysis(delta, {**DESIGN, "x4": 0.1, "x3": 0.6})
    assert inboard.frequencies_hz[0] > heavy.frequencies_hz[0]


def test_plate_thickness_scales_frequencies_and_mass_linearly(delta):
    thin = dataclasses.replace(delta, baseline=dataclasses.replace(delta.baseline, thickness_ratio=0.5))
    r0 = modal_analysis(delta, None)
    r1 = modal_analysis(thin, None)
    np.testing.assert_allclose(r1.frequencies_hz, 0.5 * r0.frequencies_hz, rtol=1e-9)
    assert math.isclose(r1.mass_kg, 0.5 * r0.mass_kg, rel_tol=1e-12)
    np.testing.assert_allclose(r1.shapes * math.sqrt(0.5), r0.shapes, rtol=1e-6, atol=1e-8 * np.abs(r0.shapes).max())


def _tip_compliance(model) -> float:
    from scipy.sparse.linalg import spsolve

    f = model.free
    load = np.zeros(model.K.shape[0])
    load[model.dofs_per_node * (model.xy.shape[0] - 1)] = 1.0  # unit force (w) at the tip trailing-edge corner
    u = spsolve(model.K[f][:, f].tocsc(), load[f])
    return float(load[f] @ u)


def test_beam_stiffens_and_fe_mesh_follows_the_beam_line(delta):
    a = modal_analysis(delta, {**DESIGN, "x4": 0.0, "x5": 0.5})
    # a mid-plane beam adds little bending stiffness: a bigger beam is stiffer statically (same FE mesh) ...
    big, small = build_model(delta, {**DESIGN, "x5": 2.0, "x6": 2.0}), build_model(delta, {**DESIGN, "x5": 0.5})
    assert _tip_compliance(big) < _tip_compliance(small)
    # ... and heavier by exactly rho * (section area difference) * beam length
    mb = big.mass_kg - small.mass_kg
    s = delta.structure_for(DESIGN)
    pf = delta.planform
    p0 = np.array([s.beam.root_position * pf.root_chord, 0.0])
    p1 = np.array(pf.to_xy(s.beam.tip_position, 1.0))
    length = float(np.linalg.norm(p1 - p0))
    assert math.isclose(mb, 2700.0 * (2e-3 * 4e-3 - 0.5e-3 * 0.6e-3) * length, rel_tol=1e-9)
    c = modal_analysis(delta, {**DESIGN, "x1": 0.6})
    assert c.n_fe_nodes == a.n_fe_nodes and not np.allclose(c.fe_xy, a.fe_xy)
    s = delta.structure_for({**DESIGN, "x1": 0.6})
    root_beam_x = 0.6 * delta.planform.root_chord
    assert np.min(np.abs(c.fe_xy[: s.fe_n_chord + 1, 0] - root_beam_x)) < 1e-12


def test_mode_signs_are_deterministic(baseline):
    imax = np.argmax(np.abs(baseline.shapes), axis=0)
    assert np.all(baseline.shapes[imax, np.arange(4)] > 0)


def test_mapped_shapes_equal_fe_values_at_coincident_nodes(delta):
    s = delta.baseline
    pf = dataclasses.replace(delta.planform, n_chord=s.fe_n_chord // 2, n_span=s.fe_n_span // 4)
    r = modal_analysis(delta, None, mesh=standard_mesh(pf))
    fe = r.fe_shapes.reshape(s.fe_n_span + 1, s.fe_n_chord + 1, -1)[::4, ::2].reshape(-1, r.n_modes)
    np.testing.assert_allclose(r.shapes, fe, rtol=0, atol=1e-12 * np.abs(fe).max())


def test_fe_interpolation_agrees_with_scattered_mapping(delta):
    r = modal_analysis(delta, DESIGN)
    ct = map_to_mesh(r.fe_xy, r.fe_shapes, standard_mesh(delta.planform))
    scale = np.abs(r.shapes).max(axis=0)
    assert np.all(np.abs(ct - r.shapes).max(axis=0) < 0.02 * scale)


def _goland_ritz(n: int = 12) -> np.ndarray:
    """Coupled bending-torsion frequencies (rad/s) by Rayleigh-Ritz on exact uncoupled cantilever modes."""
    L, m, ia, ei, gj = 6.096, 35.71, 8.64, 9.77e6, 0.99e6
    s_mom = m * 0.10 * 1.8288
    y, wq = np.polynomial.legendre.leggauss(200)
    y, wq = 0.5 * L * (y + 1), 0.5 * L * wq
    roots = [1.87510407, 4.69409113, 7.85475744, 10.99554073, 14.13716839]
    roots += [(2 * k - 1) * math.pi / 2 for k in range(6, n + 1)]
    phi = []
    for bl in roots[:n]:
        b = bl / L
        sig = (math.cosh(bl) + math.cos(bl)) / (math.sinh(bl) + math.sin(bl))
        one_minus_sig = (math.sin(bl) - math.cos(bl) - math.exp(-bl)) / (math.sinh(bl) + math.sin(bl))
        # cosh - cos - sig (sinh - sin), with cosh - sig sinh written without cancellation
        hyp = 0.5 * (one_minus_sig * np.exp(b * y) + (2.0 - one_minus_sig) * np.exp(-b * y))
        phi.append(hyp - np.cos(b * y) + sig * np.sin(b * y))
    phi = np.array(phi)
    kb = np.array(roots[:n]) ** 4 / L**4 * ei
    psi = np.array([np.sin((2 * k - 1) * math.pi * y / (2 * L)) for k in range(1, n + 1)])
    kt = np.array([((2 * k - 1) * math.pi / (2 * L)) ** 2 for k in range(1, n + 1)]) * gj
    mbb = m * (phi * wq) @ phi.T
    mtt = ia * (psi * wq) @ psi.T
    mbt = -s_mom * (phi * wq) @ psi.T
    M = np.block([[mbb, mbt], [mbt.T, mtt]])
    z = np.zeros((n, n))
    K = np.block([[np.diag(kb) @ (phi * wq) @ phi.T, z], [z, np.diag(kt) @ (psi * wq) @ psi.T]])
    from scipy.linalg import eigh

    return np.sqrt(eigh(K, M, eigvals_only=True))


def test_goland_coupled_modes_match_rayleigh_ritz_and_literature():
    r = modal_analysis(template("goland"), None, n_modes=3)
    np.testing.assert_allclose(r.omega[:3], _goland_ritz()[:3], rtol=5e-3)
    # commonly quoted coupled Goland FE frequencies: 7.66 Hz (1st bending), 15.24 Hz (1st torsion), 38.9 Hz
    np.testing.assert_allclose(r.frequencies_hz[:2], [7.66, 15.24], rtol=0.01)
    assert math.isclose(r.mass_kg, 35.71 * 6.096, rel_tol=1e-12)


def test_goland_uncoupled_frequencies_match_validation_values():
    w = template("goland")
    uncoupled = dataclasses.replace(w, structure=dataclasses.replace(w.structure, cg_chord_fraction=0.33))
    r = modal_analysis(uncoupled, None, n_modes=2)
    np.testing.assert_allclose(r.omega, [49.5, 87.0], rtol=0.02)


def test_goland_standard_mesh_shapes_follow_the_rigid_section_rule():
    w = template("goland")
    r = modal_analysis(w, None, n_modes=3)
    grid = standard_mesh(w.planform).grid(r.shapes)  # [ns+1, nc+1, k]
    np.testing.assert_allclose(np.diff(grid, 2, axis=1), 0.0, atol=1e-10 * np.abs(grid).max())
    # at the elastic axis the mapped w equals the beam nodes' w (nodes at equal span fractions)
    x = np.linspace(0.0, 1.0, w.planform.n_chord + 1) * w.planform.root_chord
    pf_nodes = w.structure.n_elements // w.planform.n_span
    w_ea = np.array([np.interp(0.33 * 1.8288, x, grid[j, :, k]) for j in range(grid.shape[0]) for k in range(3)])
    fe = r.fe_shapes[::pf_nodes].ravel()
    np.testing.assert_allclose(w_ea, fe, atol=1e-10 * np.abs(fe).max())


def test_bad_n_modes_raises(delta):
    with pytest.raises(ValueError, match="n_modes"):
        modal_analysis(delta, None, n_modes=0)
    with pytest.raises(ValueError, match="x7"):
        modal_analysis(delta, {**DESIGN, "x7": 1.5})
    assert isinstance(Planform, type)
