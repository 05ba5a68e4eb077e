"""The TSD's root symmetry (symmetric, antisymmetric, none = a free wing): the symmetric root is unchanged, the
antisymmetric root mirrors phi with the opposite sign, a free wing's grid continues below the root to a lateral far
field of its own; checked against the factors' Jacobian, the doublet lattice in the linear limit, the mirrored half
wing, and the service's identity. Numbers in docstrings are measured values."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from test_tsd_2d import TINY, _jacobians

from romams_core.aero.dlm import DlmSolver
from romams_core.aero.tsd import TsdSolver
from romams_core.aero.tsd.flow import sponge_layer
from romams_core.aero.tsd.grid import GridSpec, wing_grid
from romams_core.errors import InputError
from romams_core.mesh import Planform, StandardMesh, standard_mesh

SMALL = dict(n_chord=16, n_upstream=6, n_downstream=8, n_outboard=4, n_z=10, dz0=0.04)
SWEPT = Planform(root_chord=1.0, tip_chord=0.6, semispan=1.5, sweep_le=math.radians(20.0), n_chord=6, n_span=8)


def _rect(semispan: float, n_span: int) -> StandardMesh:
    """Flat rectangular unswept wing of unit chord from y = 0 to ``semispan`` (m)."""
    return standard_mesh(Planform(root_chord=1.0, tip_chord=1.0, semispan=semispan, n_chord=4, n_span=n_span))


def test_symmetric_root_is_unchanged():
    """A thick (NACA 4-digit 6 %) swept tapered wing at M 0.8, two shapes, 100 steady steps and 30 signal steps on a
    small grid: the GAC and the mean-flow Cp equal the numbers recorded before the root symmetry was added (there
    np.array_equal held for these and for phi after 15 raw steps on a cranked grid; the tolerance only absorbs
    another CPU's or BLAS's round-off), and the default solver is the explicit symmetric one exactly."""
    mesh = standard_mesh(dataclasses.replace(SWEPT, sweep_le=math.radians(30.0), n_span=6))
    shapes = np.column_stack([np.ones(mesh.n_nodes), mesh.y * mesh.x])
    sig = 0.002 * np.sin(np.arange(30)[:, None] * np.array([0.3, 0.5]))

    def run(**kw: str) -> tuple[np.ndarray, np.ndarray]:  # the outer faces as they were then (no wake far field,
        s = TsdSolver(thickness_form="naca4", thickness_to_chord=0.06,  # the lateral face at 2.5 semispans)
                      grid=GridSpec(n_span=6, y_outboard=2.5, **SMALL),
                      steady_steps=100, far_field="plain", **kw)
        gac = s.simulate(mesh, shapes, sig, 0.8, 0.1)
        assert s.last_mean_flow is not None
        return gac, s.last_mean_flow.cp_upper

    gac, cp = run()
    recorded = [[0.01690340796556868, 0.02396785568808251], [0.00746861267400064, 0.015973154043911177],
                [0.035671729584730444, 0.03336655442275484]]
    np.testing.assert_allclose(gac[[5, 17, 29]], recorded, rtol=1e-12, atol=0.0)
    np.testing.assert_allclose(cp[[3, 10], [2, 4]], [-0.2650271402981943, -0.051942346079797634], rtol=1e-12)
    gac_s, cp_s = run(symmetry="symmetric")
    assert np.array_equal(gac, gac_s) and np.array_equal(cp, cp_s)
    assert TsdSolver().info(0.8).description.endswith("root symmetric (symmetry plane: zero flux, the symmetric "
                                                      "half wing)")


def test_free_wing_grid_continues_below_the_root():
    """The open root's grid: faces at 0 and b, the span's faces clustered toward both edges and the outboard faces
    mirrored below the root (a rectangular wing's grid is symmetric about mid-span to 1e-15), the mapping frozen at
    the root values below it, the metric zero there and averaged on the root face, the masks on 0 < y < b, the
    absorbing layer on both lateral sides; a cranked wing keeps its stations."""
    spec = GridSpec(n_span=8, y_outboard=2.5, **SMALL)  # the lateral faces 1.5 spans beyond the edges
    g = wing_grid(3.0, 1.0, 0.0, spec, root="open")
    assert g.root == "open" and g.root_code == 2 and g.shape[1] == 8 + 2 * 4
    assert np.abs(g.yf + g.yf[::-1] - 3.0).max() < 1e-14
    assert np.min(np.abs(g.yf)) == 0.0 and np.min(np.abs(g.yf - 3.0)) < 1e-14
    assert g.yf[0] == pytest.approx(-(spec.y_outboard - 1.0) * 3.0)
    assert np.array_equal(g.strips, (g.yc > 0) & (g.yc < 3.0)) and g.strips.sum() == 8
    assert np.array_equal(g.wing.any(axis=0), g.strips) and np.array_equal(g.wake.any(axis=0), g.strips)
    lateral = sponge_layer(g, 1.0)[int(np.argmin(np.abs(g.xc - 0.5))), :, g.k0]  # across the span at the wing
    assert lateral[0] > 0.1 and lateral[g.strips].max() == 0.0
    np.testing.assert_allclose(lateral, lateral[::-1], rtol=1e-12)

    tan, taper, kinks = 0.6, 0.5, np.array([[0.7, 0.3, 0.8]])
    c = wing_grid(1.5, taper, tan, spec, kinks=kinks, root="open")
    np.testing.assert_array_equal(c.stations[:, 0], [0.0, 0.7, 1.5])
    below = np.array([-2.0, -0.3, -1e-3])
    np.testing.assert_array_equal(c.chord(below), 1.0)
    np.testing.assert_array_equal(c.x_le(below), 0.0)
    np.testing.assert_array_equal(c.xi_y(0.5, below), 0.0)
    inboard = -(0.3 / 0.7 + 0.5 * (0.8 - 1.0) / 0.7)
    assert c.xi_y(0.5, 0.0) == pytest.approx(0.5 * inboard, rel=1e-12)
    assert c.xi_y(0.5, 0.2) == pytest.approx(inboard / (1.0 + (0.8 - 1.0) * 0.2 / 0.7), rel=1e-12)
    r = wing_grid(1.5, taper, tan, spec)  # no kinks: the same freezing below the root
    np.testing.assert_array_equal(r.chord(below), 1.0)
    np.testing.assert_array_equal(r.x_le(below), 0.0)
    with pytest.raises(InputError) as e:
        wing_grid(1.5, 1.0, 0.0, spec, root="mirrored")
    assert e.value.field == "root"


@pytest.mark.parametrize("root", ["antisymmetric", "open"])
def test_factors_are_the_jacobian_at_the_root(root):
    """Rectangular wing with the 2-D coefficient set (G = H = 0), M 0.8, random phi 0.05: with the antisymmetric
    root (ghost -phi) or the open root (lateral far field below it) the three factors still carry the whole
    Jacobian, root rows included, to 1e-5 of its largest entry off the streamwise far-field rows (measured 7.6e-8
    antisymmetric and 6.3e-8 open, as 7.6e-8 with the symmetric root: the finite-difference error)."""
    g = wing_grid(1.5, 1.0, 0.0, TINY, root=root)
    jac, fac, idx, supersonic = _jacobians(g, "2d", 0.05)
    assert 0.1 < supersonic < 0.9
    rows = (idx[:, 0] > 0) & (idx[:, 0] < g.shape[0] - 1)
    assert np.abs(jac - fac)[rows].max() < 1e-5 * np.abs(jac).max()
    root_rows = rows & (idx[:, 1] == 0)
    assert np.abs(jac[root_rows]).max() > 0.0


def _ramp_hold(n: int = 200) -> np.ndarray:
    """A slow ramp to 1 over 2 t* (dt_star 0.1), then held: [n]."""
    return np.minimum(1.0, np.arange(n) / 20.0)


@pytest.mark.parametrize("symmetry", ["antisymmetric", "none"])
def test_steady_limit_matches_the_doublet_lattice(symmetry):
    """A flat swept tapered wing (semispan 1.5 root chords, taper 0.6, 20 deg) at M 0.5, pitch about the root quarter
    chord and a pitch growing linearly to the tip (0.01 rad), each ramped slowly to a hold of 18 t* (n_span 12):
    the 2 x 2 steady GAC equal the DLM's (``DlmSolver(symmetry=...)``, an independent discretization) within 5 %
    entry by entry. Measured: antisymmetric within 0.51 % (pitch-pitch -5.064e-5 against -5.090e-5 m^3), none
    (a free wing) within 1.9 % (-5.991e-5 against -5.909e-5); the symmetric root on the same grid 2.3 %."""
    mesh = standard_mesh(SWEPT)
    shapes = np.column_stack([-0.01 * (mesh.x - 0.25), -0.01 * (mesh.x - 0.25) * mesh.y / SWEPT.semispan])
    u, zero = _ramp_hold(), np.zeros(200)
    records = [np.column_stack([u, zero]), np.column_stack([zero, u])]
    tsd = TsdSolver(grid=GridSpec(n_span=12, **SMALL), symmetry=symmetry, record_threads=1)
    gac = np.column_stack([r[-1] for r in tsd.simulate_records(mesh, shapes, records, 0.5, 0.1)])
    dlm = DlmSolver(symmetry=symmetry).gaf(mesh, shapes, 0.5, np.array([0.0]))[0].real
    np.testing.assert_allclose(gac, dlm, rtol=0.05)
    assert tsd.info(0.5).description.split("), root ")[1].startswith(symmetry)


def test_free_wing_equals_the_mirrored_half_wing_of_half_its_span():
    """A free rectangular unswept wing on 0 <= y <= 3 (n_span 8, y_outboard 1.75) and the symmetric half wing of
    semispan 1.5 (n_span 4, y_outboard 2.5) have coinciding grids once the half wing is mirrored; with a thick
    section (NACA 4-digit 6 %) at M 0.8 and a random heave/pitch motion the free wing's GAC are twice the half
    wing's within 1e-9 relative (measured 4e-15), and its mean-flow Cp covers the wing's 8 stations, the mirror
    image of the half wing's 4 (1e-15)."""
    half, free = _rect(1.5, 4), _rect(3.0, 8)
    sig = 0.002 * np.random.default_rng(0).standard_normal((40, 2))

    def run(mesh: StandardMesh, spec: GridSpec, symmetry: str) -> tuple[np.ndarray, TsdSolver]:
        shapes = np.column_stack([np.ones(mesh.n_nodes), -mesh.x])
        s = TsdSolver(thickness_form="naca4", thickness_to_chord=0.06, grid=spec, symmetry=symmetry,
                      steady_steps=100)
        return s.simulate(mesh, shapes, sig, 0.8, 0.1), s

    g_half, s_half = run(half, GridSpec(n_span=4, y_outboard=2.5, **SMALL), "symmetric")
    g_free, s_free = run(free, GridSpec(n_span=8, y_outboard=1.75, **SMALL), "none")
    assert np.abs(g_free - 2.0 * g_half).max() <= 1e-9 * np.abs(g_free).max()
    mh, mf = s_half.last_mean_flow, s_free.last_mean_flow
    assert mh is not None and mf is not None
    assert mf.cp_upper.shape == (16, 8) and np.all((mf.eta > 0) & (mf.eta < 1))
    np.testing.assert_allclose(mf.cp_upper[:, 4:], mh.cp_upper, atol=1e-12)
    np.testing.assert_allclose(mf.cp_upper[:, 3::-1], mh.cp_upper, atol=1e-12)


def test_antisymmetric_root_lifts_less_and_rolls():
    """A flat rectangular half wing (semispan 1.5, unit chord) at M 0.5 on a coarse grid (n_span 6): the lift of
    the heave shape per unit incidence (ramped to a hold of 13 t*) is 0.0553 symmetric, 0.0365 free and 0.0297
    antisymmetric (m^3 per 0.01 rad; the image's opposite loading cancels lift near the root), so that the free and
    the antisymmetric lift are 0.660 and 0.538 of the symmetric one against the DLM's 0.648 and 0.538 (within 5 %);
    a roll shape h = y rolled at a constant rate gives a rolling moment of damping sign (-2.10e-4 antisymmetric,
    -2.81e-4 symmetric)."""
    mesh = _rect(1.5, 6)
    shapes = np.column_stack([np.ones(mesh.n_nodes), -0.01 * mesh.x, 0.01 * mesh.y])  # heave, incidence, roll
    ramp, zero = _ramp_hold(150), np.zeros(150)
    records = [np.column_stack([zero, ramp, zero]), np.column_stack([zero, zero, 0.1 * np.cumsum(ramp)])]
    lift, roll, dlm = {}, {}, {}
    for sym in ("symmetric", "antisymmetric", "none"):
        gac = TsdSolver(grid=GridSpec(n_span=6, **SMALL), symmetry=sym, record_threads=1).simulate_records(
            mesh, shapes, records, 0.5, 0.1)
        lift[sym], roll[sym] = gac[0][-1, 0], gac[1][-1, 2]
        dlm[sym] = DlmSolver(symmetry=sym).gaf(mesh, shapes, 0.5, np.array([0.0]))[0, 0, 1].real
    assert 0.0 < lift["antisymmetric"] < lift["none"] < lift["symmetric"]
    for sym in ("antisymmetric", "none"):
        assert lift[sym] / lift["symmetric"] == pytest.approx(dlm[sym] / dlm["symmetric"], rel=0.05)
    assert roll["symmetric"] < roll["antisymmetric"] < -0.5 * abs(roll["symmetric"])


def test_bad_symmetry_is_refused_and_the_service_trains_the_tsd_with_the_wings(monkeypatch):
    """An unknown symmetry is an InputError naming ``symmetry`` (solver, trainer) or InvalidInput naming
    ``options.symmetry`` (service); rom_identity puts a non-symmetric wing's symmetry into a tsd ROM's options
    (a symmetric wing's identity names none), and the training's solver carries it."""
    from romams.services.errors import InvalidInput
    from romams.services.training import allowed_options, check_options, rom_identity, train
    from romams_core import training_tsd
    from romams_core.wing import template

    for bad in ("mirrored", None):
        with pytest.raises(InputError) as e:
            TsdSolver(symmetry=bad)  # type: ignore[arg-type]
        assert e.value.field == "symmetry"
    mesh = _rect(1.5, 4)
    with pytest.raises(InputError) as e:
        training_tsd.train_tsd_rom(mesh, np.ones((mesh.n_nodes, 1)), 0.8, symmetry="mirrored")
    assert e.value.field == "symmetry"
    with pytest.raises(InvalidInput) as ei:
        check_options("tsd", {"symmetry": "mirrored"})
    assert ei.value.field == "options.symmetry"
    assert "symmetry" in allowed_options("tsd")

    wing = dataclasses.replace(template("cropped-delta"), symmetry="antisymmetric")
    ident = rom_identity("tsd", 4, 4, wing=wing)
    assert ident["options"]["symmetry"] == "antisymmetric"
    assert "symmetry" not in rom_identity("tsd", wing=template("cropped-delta"))["options"]
    assert rom_identity("tsd", wing=dataclasses.replace(wing, symmetry="none"))["options"]["symmetry"] == "none"

    seen: list[str] = []

    class Stop(Exception):
        pass

    def fake_train_rom(mesh, shapes, mach, solver, **kw):  # the ARX training of the TSD's records
        seen.append(solver.symmetry)
        raise Stop

    monkeypatch.setattr(training_tsd, "train_rom", fake_train_rom)
    with pytest.raises(Stop):
        train(mesh, 0.01 * np.ones((mesh.n_nodes, 1)), 0.8, ident)
    assert seen == ["antisymmetric"]
