"""A cranked planform (two trapezoids, a kink in the leading edge and the chord) through the linear solvers."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from romams_core.aero.dlm import DlmSolver
from romams_core.aero.uvlm import frequency_response, refine_mesh
from romams_core.mesh import Planform, standard_mesh
from romams_core.wing import template

CRANKED = Planform(root_chord=1.0, tip_chord=0.5, semispan=2.0, sweep_le=math.atan(0.6 / 2.0), n_chord=6, n_span=8,
                   kinks=((1.0, 0.1, 0.8),))


def _heave_pitch(mesh):
    """Heave (1 m) and pitch about the root quarter chord (0.01 rad) on the mesh, [N, 2]."""
    return np.column_stack([np.ones(mesh.n_nodes), -0.01 * (mesh.x - 0.25)])


def test_refined_cranked_mesh_keeps_the_kink_and_maps_shapes_exactly():
    """refine_mesh splits every panel in equal parts: the kink stays a node row, and its bilinear map gives a
    field bilinear in the planform's (xi, eta) exactly at the fine nodes."""
    mesh = standard_mesh(CRANKED)
    fine, interp = refine_mesh(mesh, 3)
    assert fine.n_span == 24 and np.any(np.isclose(fine.eta * 2.0, 1.0, atol=1e-12))
    np.testing.assert_allclose(fine.eta[::3], mesh.eta, atol=1e-15)

    def field(m):
        xi, eta = CRANKED.to_xi_eta(m.x, m.y)
        return 0.2 + 0.5 * xi - 0.3 * eta + 0.7 * xi * eta

    np.testing.assert_allclose(interp @ field(mesh), field(fine), atol=1e-12)


def test_refined_mesh_keeps_rows_given_to_the_standard_mesh():
    """Rows given to standard_mesh on a planform without kinks (here clustered to the tip) stay node rows of the
    refined lattice, and the DLM's steady pitch GAC on such a mesh equals the one on the uniform mesh within the
    lattices' own difference (0.6 % measured at refine 2; before the fix the refined lattice was uniform while
    the shapes came from the clustered rows: 16 tip-clustered rows on AGARD's planform put a steady GAC 43 % off)."""
    pf = dataclasses.replace(template("agard-445.6").planform, n_span=8)
    rows = np.sin(np.linspace(0.0, np.pi / 2, 9))
    mesh = standard_mesh(pf, rows)
    fine, interp = refine_mesh(mesh, 2)
    np.testing.assert_allclose(fine.eta[::2], rows, atol=1e-15)
    np.testing.assert_allclose(interp @ mesh.y, fine.y, atol=1e-12)
    uniform = standard_mesh(pf)
    pitch = [DlmSolver(refine=2).gaf(m, -0.01 * (m.x - 0.25)[:, None], 0.7, np.array([0.001]))[0, 0, 0].real
             for m in (mesh, uniform)]
    assert abs(pitch[0] / pitch[1] - 1.0) < 0.02


def test_doublet_and_vortex_lattice_agree_on_a_cranked_wing():
    """Steady-ish (k 0.05) and unsteady (k 0.5) GAF of heave and pitch at M 0.3 on the cranked wing: the
    panelaero doublet lattice and the built-in vortex lattice (two independent discretizations of the same
    linear potential flow) agree within 3 % (k 0.05) and 6 % (k 0.5) of the largest entry; measured 1.9 % and
    4.0 % (the UVLM's quasi-steady compressibility and slow lattice convergence of the out-of-phase part: the same
    size as on the trapezoids of docs/aerodynamics.md). The DLM's lift slope is 4.25 /rad against 4.75 from the
    lifting-line estimate 2 pi A / (A + 2) / beta, which ignores the sweep (15 % allowed)."""
    mesh = standard_mesh(CRANKED)
    shapes = _heave_pitch(mesh)
    k = np.array([0.05, 0.5])
    dlm = DlmSolver(refine=2).gaf(mesh, shapes, 0.3, k)
    uvlm = frequency_response(mesh, shapes, 0.3, k, refine=2)
    for n, tol in enumerate((0.03, 0.06)):
        err = np.abs(uvlm[n] - dlm[n]).max() / np.abs(dlm[n]).max()
        assert err < tol, (k[n], err, dlm[n], uvlm[n])
    # the lift of a unit pitch (row heave, column pitch) is positive-up for nose-up pitch and ~2 pi AR/(AR+2)
    area = CRANKED.area
    cl_alpha = dlm[0, 0, 1].real / 0.01 / area
    aspect = (2 * CRANKED.semispan) ** 2 / (2 * area)
    assert cl_alpha == pytest.approx(2 * math.pi * aspect / (aspect + 2) / math.sqrt(1 - 0.09), rel=0.15)


def test_tsd_steady_limit_on_a_cranked_wing_matches_the_doublet_lattice():
    """A flat cranked wing at M 0.5 pitched slowly to a hold (small TSD grid): the pitch-pitch GAC at the end
    of the hold equals the DLM's steady value within 5 %; measured 1.2 % (coarse TSD grid of 16 chordwise cells,
    the sheared grid following the kink)."""
    from romams_core.aero.tsd import TsdSolver
    from romams_core.aero.tsd.grid import GridSpec

    mesh = standard_mesh(CRANKED)
    pitch = _heave_pitch(mesh)[:, 1:]
    spec = GridSpec(n_chord=16, n_upstream=6, n_downstream=8, n_span=12, n_outboard=4, n_z=10, dz0=0.04)
    u = np.minimum(1.0, np.arange(120) / 20.0)[:, None]
    tsd = TsdSolver(grid=spec).simulate(mesh, pitch, u, 0.5, 0.1)[-1, 0]
    dlm = DlmSolver().gaf(mesh, pitch, 0.5, np.array([0.0]))[0, 0, 0].real
    assert tsd == pytest.approx(dlm, rel=0.05)
