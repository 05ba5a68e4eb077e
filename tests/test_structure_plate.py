"""Cantilever plates: Leissa's square plate, mesh convergence, orthotropic strip against beam theory."""

import dataclasses
import math

import numpy as np
import pytest

from romams_core.mesh import Planform
from romams_core.structure.modal import modal_analysis, naca4_thickness_form
from romams_core.wing import PlateMaterial, PlateStructure, WingDefinition

LEISSA = np.array([3.49, 8.53, 21.4, 27.3, 31.1])  # omega a^2 sqrt(rho h / D), C-F-F-F square plate, nu = 0.3
E, NU, RHO, H, SIDE = 70e9, 0.3, 2700.0, 2.0e-3, 0.5


def _square_plate_lambdas(n: int) -> np.ndarray:
    pf = Planform(SIDE, SIDE, SIDE, 0.0, 4, 4)
    s = PlateStructure(material=PlateMaterial.isotropic(E, NU, RHO), thickness=H, fe_n_chord=n, fe_n_span=n)
    r = modal_analysis(WingDefinition("square", pf, s), n_modes=5)
    d = E * H**3 / (12 * (1 - NU**2))
    return r.omega * SIDE**2 * math.sqrt(RHO * H / d)


def test_cantilever_square_plate_matches_leissa_within_2_percent():
    lam = _square_plate_lambdas(16)
    np.testing.assert_allclose(lam, LEISSA, rtol=0.02)


def test_cantilever_square_plate_converges_under_refinement():
    ref = _square_plate_lambdas(48)
    np.testing.assert_allclose(ref, LEISSA, rtol=0.01)
    errs = [np.max(np.abs(_square_plate_lambdas(n) / ref - 1.0)) for n in (3, 6, 12, 24)]
    assert all(b < a for a, b in zip(errs, errs[1:], strict=False)), errs
    assert errs[-1] < 2e-3


@pytest.mark.parametrize("orientation", [0.0, math.pi / 2])
def test_orthotropic_narrow_cantilever_strip_matches_beam_theory(orientation):
    # nu12 = 0: a narrow strip bends as an Euler-Bernoulli beam with EI = E_span h^3 b / 12
    e1, e2, chord, span = 40e9, 10e9, 0.05, 1.0
    mat = PlateMaterial(E1=e1, E2=e2, G12=5e9, nu12=0.0, density=1500.0, orientation=orientation)
    pf = Planform(chord, chord, span, 0.0, 2, 10)
    s = PlateStructure(material=mat, thickness=H, fe_n_chord=2, fe_n_span=40)
    r = modal_analysis(WingDefinition("strip", pf, s), n_modes=1)
    e_span = e1 if orientation == 0.0 else e2
    exact = 1.8751**2 * math.sqrt(e_span * H**3 / 12 / (1500.0 * H * span**4))
    assert math.isclose(r.omega[0], exact, rel_tol=5e-3)


@pytest.mark.parametrize("degrees", [30.0, 45.0])
def test_rotated_orthotropic_cantilever_strip_tends_to_beam_theory(degrees):
    # axis 1 at an angle to the span: a narrow strip with free sides bends with the axial compliance,
    # E_eff = 1 / (Qbar^-1)_yy (bending-twist and anticlastic coupling free). The clamped root restrains them over
    # about one chord, so the error is O(chord / span): it must halve with the chord (checks the rotated D16, D26)
    mat = PlateMaterial(E1=40e9, E2=10e9, G12=5e9, nu12=0.25, density=1500.0, orientation=math.radians(degrees))
    e_eff = 1.0 / np.linalg.inv(mat.plane_stress_q())[1, 1]
    exact = 1.8751**2 * math.sqrt(e_eff * H**2 / 12 / (1500.0 * 1.0**4))
    errs = []
    for chord in (0.05, 0.025):
        s = PlateStructure(material=mat, thickness=H, fe_n_chord=2, fe_n_span=80)
        r = modal_analysis(WingDefinition("strip", Planform(chord, chord, 1.0, 0.0, 2, 10), s), n_modes=1)
        errs.append(r.omega[0] / exact - 1.0)
    assert 0.0 < errs[1] < 0.008 and 0.4 < errs[1] / errs[0] < 0.6, errs


def test_airfoil_thickness_form_mass_and_scaling():
    pf = Planform(0.5, 0.3, 0.8, math.radians(40.0), 6, 8)
    mat = PlateMaterial(E1=3.151e9, E2=0.4162e9, G12=0.4392e9, nu12=0.31, density=382.0)
    s = PlateStructure(material=mat, thickness_form="naca4", thickness_to_chord=0.04, min_thickness_fraction=0.0,
                       fe_n_chord=24, fe_n_span=16)
    r = modal_analysis(WingDefinition("agard-like", pf, s), n_modes=3)
    # mass = rho * (t/c) * int c(y)^2 dy * (chordwise mean of the NACA form normalized to max 1)
    mean_form = 0.2969 * 2 / 3 - 0.1260 / 2 - 0.3516 / 3 + 0.2843 / 4 - 0.1015 / 5
    int_c2 = (0.5**2 + 0.5 * 0.3 + 0.3**2) / 3 * 0.8  # integral of chord^2 over the span, m^3
    expected = 382.0 * 0.04 * int_c2 * mean_form / 0.10002879
    assert math.isclose(r.mass_kg, expected, rel_tol=0.01)
    assert math.isclose(naca4_thickness_form(np.linspace(0.0, 1.0, 20001)).max(), 1.0, rel_tol=1e-6)
    r2 = modal_analysis(WingDefinition("agard-like", pf, dataclasses.replace(s, thickness_ratio=2.0)), n_modes=3)
    np.testing.assert_allclose(r2.frequencies_hz, 2.0 * r.frequencies_hz, rtol=1e-9)
