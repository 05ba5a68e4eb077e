"""DKT plate and Euler-Bernoulli beam elements: patch tests, exact mass integrals, closed-form beam modes."""

import math

import numpy as np
import pytest
from scipy.integrate import dblquad

from romams_core.mesh import Planform
from romams_core.structure.beam import beam_element_matrices, rectangle_torsion_constant
from romams_core.structure.dkt import cubic_mass, curvature_matrices, dkt_stiffness, triangle_geometry
from romams_core.structure.modal import modal_analysis
from romams_core.wing import BeamStructure, WingDefinition

TRIS = np.array([[[0.0, 0.0], [1.2, 0.1], [0.3, 0.9]], [[0.1, 0.2], [0.9, -0.3], [0.8, 0.7]]])
A, B, C = 0.7, -0.3, 0.45  # w = A x^2/2 + B y^2/2 + C x y: curvatures (A, B, 2C)


def _quadratic_dofs(xy):
    x, y = xy[..., 0], xy[..., 1]
    w = A * x**2 / 2 + B * y**2 / 2 + C * x * y
    return np.stack([w, A * x + C * y, B * y + C * x], axis=-1).reshape(xy.shape[0], 9)


def test_dkt_constant_curvature_patch_test():
    b, _ = curvature_matrices(TRIS)
    kappa = np.einsum("egij,ej->egi", b, _quadratic_dofs(TRIS))
    np.testing.assert_allclose(kappa, np.broadcast_to([A, B, 2 * C], kappa.shape), rtol=1e-12, atol=1e-12)


def test_dkt_stiffness_has_three_rigid_modes_and_exact_energy():
    d = np.broadcast_to(np.array([[2.0, 0.6, 0.1], [0.6, 1.5, 0.2], [0.1, 0.2, 0.7]]), (2, 3, 3))
    k = dkt_stiffness(TRIS, d)
    ev = np.linalg.eigvalsh(k)
    assert np.all(np.abs(ev[:, :3]) < 1e-10 * ev[:, -1:]) and np.all(ev[:, 3:] > 1e-6 * ev[:, -1:])
    u = _quadratic_dofs(TRIS)
    kap = np.array([A, B, 2 * C])
    area, _, _ = triangle_geometry(TRIS)
    np.testing.assert_allclose(np.einsum("ei,eij,ej->e", u, k, u), area * (kap @ d[0] @ kap), rtol=1e-12)


def test_cubic_mass_integrates_quadratic_w_squared_exactly():
    m = cubic_mass(TRIS, np.array([1.0, 2.0]))
    area, _, _ = triangle_geometry(TRIS)
    u = _quadratic_dofs(TRIS)
    for e in range(2):
        p0, p1, p2 = TRIS[e]

        def w2(t, s, p0=p0, p1=p1, p2=p2):
            x, y = p0 + s * (p1 - p0) + t * (p2 - p0)
            return (A * x**2 / 2 + B * y**2 / 2 + C * x * y) ** 2

        exact = dblquad(w2, 0, 1, 0, lambda s: 1 - s)[0] * 2 * area[e] * (e + 1.0)
        assert math.isclose(u[e] @ m[e] @ u[e], exact, rel_tol=1e-10)
    rigid = np.tile([1.0, 0.0, 0.0], 3)
    np.testing.assert_allclose(rigid @ m @ rigid, area * [1.0, 2.0], rtol=1e-13)


def test_rectangle_torsion_constant_matches_tabulated_values():
    # J = k a b^3 with k(1) = 0.1406, k(2) = 0.229, k(10) = 0.312 (Timoshenko & Goodier)
    for ratio, k in ((1.0, 0.1406), (2.0, 0.229), (10.0, 0.312)):
        assert math.isclose(rectangle_torsion_constant(ratio, 1.0), k * ratio, rel_tol=5e-3)


@pytest.mark.parametrize("angle", [0.0, 0.6])
def test_beam_element_rigid_motions_are_strain_free(angle):
    t = np.array([math.sin(angle), math.cos(angle)])
    xy = np.array([[[0.0, 0.0], 0.4 * t]])
    k, m = beam_element_matrices(xy, 3.0, 2.0, 1.5, 0.2, 0.1)
    a, bx, by = 0.3, -0.7, 1.1  # w = a + bx x + by y
    u = np.array([a, bx, by, a + bx * xy[0, 1, 0] + by * xy[0, 1, 1], bx, by])
    np.testing.assert_allclose(k[0] @ u, 0.0, atol=1e-12)
    assert np.all(np.linalg.eigvalsh(m[0]) > 0)


def test_cantilever_euler_bernoulli_beam_first_three_frequencies():
    ei, mpl, length = 2.0e4, 3.0, 2.5
    pf = Planform(0.2, 0.2, length, 0.0, 2, 10)
    s = BeamStructure(EI=ei, GJ=1e9, mass_per_length=mpl, inertia_ea_per_length=1e-3, ea_chord_fraction=0.5,
                      cg_chord_fraction=0.5, n_elements=20)
    r = modal_analysis(WingDefinition("cantilever", pf, s), n_modes=3)
    exact = np.array([1.8751, 4.6941, 7.8548]) ** 2 * math.sqrt(ei / (mpl * length**4))
    np.testing.assert_allclose(r.omega, exact, rtol=5e-3)
    assert math.isclose(r.mass_kg, mpl * length, rel_tol=1e-12)
