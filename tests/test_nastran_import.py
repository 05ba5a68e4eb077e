"""Nastran in: planform from CAERO1/AERO, modes from OP2 (SOL 103 and SOL 145 files), selections, units, splines.

The decks are written here with pyNastran; the OP2 eigenvectors come from the project's plate FE and from a
numpy beam FE (tests/nastran_decks.py). Skipped only when pyNastran is missing and CI is not set.
"""

from __future__ import annotations

import math
import warnings

import nastran_decks as nd  # tests/nastran_decks.py: skips this module without pyNastran (not under CI)
import numpy as np
import pytest
from scipy.spatial import cKDTree

from romams_core.mesh import Planform, standard_mesh
from romams_core.modes_io import external_modal_result
from romams_core.nastran import NastranOptions, load_modes_nastran, read_bdf, scrub, wing_from_bdf
from romams_core.structure.modal import modal_analysis
from romams_core.structure.splines import beam_spline, surface_spline
from romams_core.wing import ALUMINIUM, PlateStructure, WingDefinition

#: leading edge x = 0.4 y: corner coordinates exact in the CAERO1's 8-character fields
PLATE = Planform(root_chord=0.4, tip_chord=0.2, semispan=0.5, sweep_le=math.atan(0.4), n_chord=6, n_span=8)
ORIGIN = np.array([1.2, 0.5, 0.1])  # the deck's wing root leading edge: not at the origin
REL = 1e-6  # coincident-point tolerance, relative to each mode's largest |T3|


@pytest.fixture(scope="module")
def plate(tmp_path_factory):
    """A plate wing deck (CTRIA3 on the project's FE mesh, 2 CAERO1 panels, AERO) and its SOL 103 OP2."""
    tmp = tmp_path_factory.mktemp("plate")
    wing = WingDefinition("plate", PLATE, PlateStructure(material=ALUMINIUM, thickness=2e-3, fe_n_chord=12,
                                                         fe_n_span=16))
    modal = modal_analysis(wing, None, 4)
    bdf, nids = nd.plate_deck(tmp, wing, modal, ORIGIN)
    data = np.zeros((4, nids.size, 6))
    data[:, :, 2] = modal.fe_shapes.T
    op2 = nd.write_op2(tmp / "plate.op2", nd.eigenvector_table(nids, data, modal.frequencies_hz))
    return {"tmp": tmp, "bdf": bdf, "op2": op2, "nids": nids, "modal": modal, "wing": wing}


def _op2_t3(op2_path):
    """What pyNastran reads back from an OP2: frequencies (Hz) and T3 [n, k] of its one eigenvector table."""
    op2 = nd.OP2(debug=None)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # np.chararray inside pyNastran 1.4.1
        op2.read_op2(str(op2_path), build_dataframe=False)
    vec = next(iter(op2.eigenvectors.values()))
    return np.sqrt(np.asarray(vec.eigns, dtype=float)) / (2 * np.pi), np.asarray(vec.data, dtype=float)


def _coincident(mesh, xy):
    """(standard-mesh node index, FE node index) pairs at the same position (within 1e-9 m)."""
    dist, idx = cKDTree(xy).query(np.column_stack([mesh.x, mesh.y]))
    hit = np.flatnonzero(dist < 1e-9)
    return hit, idx[hit]


@pytest.mark.parametrize("spline", ["surface", "clough-tocher"])
def test_plate_round_trip(plate, spline):
    """The issue's contract: planform and modes from the deck; frequencies = the OP2's; mapped shapes = T3."""
    wing = wing_from_bdf(plate["bdf"])
    assert wing.structure is None and wing.symmetry == "symmetric"
    np.testing.assert_allclose(wing.origin, ORIGIN, atol=1e-12)
    pf = wing.planform
    np.testing.assert_allclose([pf.root_chord, pf.tip_chord, pf.semispan, pf.sweep_le],
                               [PLATE.root_chord, PLATE.tip_chord, PLATE.semispan, PLATE.sweep_le], rtol=1e-9)
    assert (pf.n_chord, pf.n_span) == (6, 8)  # NCHORD 6; NSPAN 4 + AEFACT of 5 fractions (4 boxes)
    assert wing.reference_chord == pytest.approx(0.4)
    modes = load_modes_nastran(plate["bdf"], plate["op2"])
    f_op2, data = _op2_t3(plate["op2"])
    np.testing.assert_allclose(modes.frequencies_hz, f_op2, rtol=1e-12)
    np.testing.assert_allclose(modes.frequencies_hz, plate["modal"].frequencies_hz, rtol=1e-6)
    assert modes.mass_kg == pytest.approx(plate["modal"].mass_kg, rel=1e-9)  # CTRIA3 + PSHELL + MAT1 mass
    mesh = standard_mesh(pf)
    res = external_modal_result(modes, mesh, spline=spline, origin=wing.origin)
    hit, fe = _coincident(mesh, modes.nodes[:, :2] - ORIGIN[:2])
    assert hit.size == mesh.n_nodes  # the FE mesh refines the standard mesh: every node coincides
    t3 = data[:, :, 2].T[fe]  # [hits, k]
    sign = np.sign(np.sum(res.shapes[hit] * t3, axis=0))
    err = np.abs(res.shapes[hit] * sign - t3).max(axis=0) / np.abs(t3).max(axis=0)
    assert err.max() < REL, err


def test_stick_model_beam_spline(tmp_path):
    """A CBAR stick model: T3, R1, R2 from the OP2 through the beam spline; coincident nodes equal T3."""
    pf = Planform(root_chord=0.3, tip_chord=0.3, semispan=0.5, sweep_le=0.0, n_chord=6, n_span=10)
    bdf, op2, y, _ = nd.stick_deck(tmp_path, pf)
    x_axis = nd.STICK_X  # mid-chord, a standard-mesh line
    wing = wing_from_bdf(bdf)
    modes = load_modes_nastran(bdf, op2)
    mesh = standard_mesh(wing.planform)
    res = external_modal_result(modes, mesh, origin=wing.origin)  # auto: a stick with rotations -> beam
    _, read = _op2_t3(op2)
    t3, r2 = read[:, :, 2].T, read[:, :, 4].T
    hit, fe = _coincident(mesh, modes.nodes[:, :2])
    assert hit.size == y.size
    sign = np.sign(np.sum(res.shapes[hit] * t3[fe], axis=0))
    scale = np.abs(t3).max(axis=0)
    assert (np.abs(res.shapes[hit] * sign - t3[fe]).max(axis=0) / scale).max() < REL
    # every node of a span station moves with its rigid chordwise section: w = T3 - R2 (x - x_axis)
    station = np.rint(mesh.y / 0.05).astype(int)
    rigid = t3[station] - r2[station] * (mesh.x - x_axis)[:, None]
    assert (np.abs(res.shapes * sign - rigid).max(axis=0) / np.abs(rigid).max(axis=0)).max() < REL
    with pytest.raises(ValueError, match="nodes: the FE nodes are collinear"):
        external_modal_result(modes, mesh, spline="surface")


def test_sol145_op2_with_complex_eigenvalues(plate):
    """An OP2 with the flutter run's CLAMA table next to LAMA and the real eigenvectors reads the real modes."""
    modal, nids = plate["modal"], plate["nids"]
    gm = np.array([2.0, 0.5, 1.0, 4.0])
    data = np.zeros((4, nids.size, 6))
    data[:, :, 2] = (modal.fe_shapes * np.sqrt(gm)).T
    freqs = modal.frequencies_hz
    for tables in ([nd.real_eigenvalues(freqs, gm), nd.flutter_eigenvalues()], [nd.flutter_eigenvalues()]):
        op2 = nd.write_tables(plate["tmp"] / "sol145.op2", [*tables, nd.eigenvector_table(nids, data, freqs)])
        m = load_modes_nastran(plate["bdf"], op2)
        np.testing.assert_allclose(m.frequencies_hz, freqs, rtol=1e-6)
        if len(tables) == 2:
            np.testing.assert_allclose(m.generalized_masses, gm, rtol=1e-6)
            np.testing.assert_allclose(m.mass_normalized_shapes(), modal.fe_shapes, rtol=1e-5, atol=1e-6)
        else:
            assert m.generalized_masses is None


def test_mode_selection_and_rigid_body_skip(plate):
    modal, nids = plate["modal"], plate["nids"]
    freqs = np.array([1e-4, -2e-4, *modal.frequencies_hz[:3]])  # two rigid-body modes first (one negative)
    data = np.zeros((5, nids.size, 6))
    data[:2, :, 2] = 1.0
    data[2:, :, 2] = modal.fe_shapes[:, :3].T
    op2 = nd.write_tables(plate["tmp"] / "rigid.op2", [nd.eigenvector_table(nids, data, freqs)])
    with pytest.raises(ValueError, match="frequencies_hz: negative eigenvalues .* skip_below_hz"):
        load_modes_nastran(plate["bdf"], op2)
    skip = NastranOptions(skip_below_hz=0.5)
    m = load_modes_nastran(plate["bdf"], op2, options=skip)
    np.testing.assert_allclose(m.frequencies_hz, modal.frequencies_hz[:3], rtol=1e-6)
    two = load_modes_nastran(plate["bdf"], op2, options=NastranOptions(skip_below_hz=0.5, modes="2"))
    np.testing.assert_allclose(two.frequencies_hz, modal.frequencies_hz[:2], rtol=1e-6)
    ids = load_modes_nastran(plate["bdf"], op2, options=NastranOptions(skip_below_hz=0.5, modes="3,5"))
    np.testing.assert_allclose(ids.frequencies_hz, modal.frequencies_hz[[0, 2]], rtol=1e-6)
    with pytest.raises(ValueError, match=r"modes: mode ids \[1\] are not among the kept modes"):
        load_modes_nastran(plate["bdf"], op2, options=NastranOptions(skip_below_hz=0.5, modes="1,3"))
    with pytest.raises(ValueError, match="modes: asks for 9 modes; 3 are available"):
        load_modes_nastran(plate["bdf"], op2, options=NastranOptions(skip_below_hz=0.5, modes=9))
    with pytest.raises(ValueError, match=r"subcase: 2 not in rigid.op2 \(has \[1\]\)"):
        load_modes_nastran(plate["bdf"], op2, subcase=2)
    with pytest.raises(ValueError, match="modes: 'x' is not an id"):
        NastranOptions(modes="1,x")


def test_grid_selection(plate, tmp_path):
    """Extra GRIDs (a fuselage line outside the planform; an RBE2 master above a plate node) are left out."""
    modal, nids = plate["modal"], plate["nids"]
    model = read_bdf(plate["bdf"])
    fus = np.arange(9001, 9041)
    for i, nid in enumerate(fus):
        model.add_grid(int(nid), [ORIGIN[0] + 0.02 * i, ORIGIN[1] - 0.3, ORIGIN[2]])
    master_xy = modal.fe_xy[50]
    model.add_grid(9100, [master_xy[0] + ORIGIN[0], master_xy[1] + ORIGIN[1], ORIGIN[2] + 0.01])
    model.add_rbe2(9200, 9100, "123456", [int(nids[50])])
    bdf = tmp_path / "extra.bdf"
    model.write_bdf(str(bdf))
    all_ids = np.concatenate([nids, fus, [9100]])
    data = np.zeros((4, all_ids.size, 6))
    data[:, : nids.size, 2] = modal.fe_shapes.T
    data[:, nids.size:, 2] = modal.fe_shapes[50][:, None]  # the fuselage and the master move with node 51 (any values)
    op2 = nd.write_op2(tmp_path / "extra.op2", nd.eigenvector_table(all_ids, data, modal.frequencies_hz))
    mesh = standard_mesh(PLATE)
    every = load_modes_nastran(bdf, op2)
    with pytest.raises(ValueError, match="nodes: only 8[0-9]% of the FE nodes lie on the planform"):
        external_modal_result(every, mesh, origin=ORIGIN)
    inside = load_modes_nastran(bdf, op2, options=NastranOptions(grids="planform"))
    assert inside.grid_ids.tolist() == [*nids.tolist(), 9100]  # the fuselage GRIDs are outside the CAERO1s
    with pytest.raises(ValueError, match="nodes: two or more nodes share the same in-plane position"):
        external_modal_result(inside, mesh, origin=ORIGIN)
    listed = load_modes_nastran(bdf, op2, options=NastranOptions(grids=f"1-{nids.size}"))
    res = external_modal_result(listed, mesh, origin=ORIGIN, spline="surface")
    np.testing.assert_allclose(res.frequencies_hz, modal.frequencies_hz, rtol=1e-6)
    with pytest.raises(ValueError, match="grids: the selection keeps 2 GRIDs"):
        load_modes_nastran(bdf, op2, options=NastranOptions(grids="9001,9002"))


def test_units_and_wtmass(tmp_path):
    """A stick model in mm-t-s gives the SI model's shapes; the mass is WTMASS x sum(CONM2) x the mass unit."""
    y, freqs, phi = nd.beam_modes(n_el=6, semispan=0.5)
    out = {}
    for units, length, mass_unit in (("si", 1.0, 1.0), ("mm-t-s", 1e-3, 1e3)):
        model = nd.BDF(debug=None)
        nids = np.arange(1, y.size + 1)
        for nid, yy in zip(nids, y, strict=True):
            model.add_grid(int(nid), [0.15 / length, float(yy) / length, 0.0])
            model.add_conm2(100 + int(nid), int(nid), 0.2 / mass_unit / 0.25)  # 0.2 kg once times WTMASS 0.25
        model.add_param("WTMASS", [0.25])
        bdf = nd.finish_deck(model, tmp_path / f"{units}.bdf")
        # the same physical modes in the deck's units, mass-normalized there: displacements x sqrt(M_unit),
        # rotations x sqrt(M_unit) x length (generalized mass in the deck's units = SI / (M_unit length^2))
        data = np.zeros((freqs.size, y.size, 6))
        data[:, :, 2] = (phi[:, 0] * np.sqrt(mass_unit)).T
        data[:, :, 3] = (phi[:, 1] * np.sqrt(mass_unit) * length).T
        data[:, :, 4] = (phi[:, 2] * np.sqrt(mass_unit) * length).T
        op2 = nd.write_op2(tmp_path / f"{units}.op2", nd.eigenvector_table(nids, data, freqs))
        out[units] = load_modes_nastran(bdf, op2, options=NastranOptions(units=units))
        assert out[units].mass_kg == pytest.approx(0.2 * y.size, rel=1e-9)
        over = load_modes_nastran(bdf, op2, options=NastranOptions(units=units, wtmass=0.5))
        assert over.mass_kg == pytest.approx(0.4 * y.size, rel=1e-9)
    si, mm = out["si"], out["mm-t-s"]
    np.testing.assert_allclose(mm.nodes, si.nodes, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(mm.mass_normalized_shapes(), si.mass_normalized_shapes(), rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(mm.mass_normalized_rotations(), si.mass_normalized_rotations(), rtol=1e-6,
                               atol=1e-9)
    np.testing.assert_allclose(si.mass_normalized_shapes(), phi[:, 0], rtol=1e-6, atol=1e-9)


def test_planform_cards(tmp_path):
    """Chordwise panel pairs merge; AERO symmetry and TABDMP1 damping are honoured."""
    model = nd.BDF(debug=None)
    model.add_paero1(1)
    for eid, (x0, c) in enumerate(((0.0, 0.3), (0.3, 0.1)), start=1):  # wing box + flap panel, rectangular
        model.add_caero1(eid * 100, 1, 1, [2.0 + x0, 1.0, 0.0], c, [2.0 + x0, 2.0, 0.0], c, nspan=5, nchord=4)
    model.add_aeros(cref=0.35, bref=2.0, sref=0.4, sym_xz=-1)
    model.add_tabdmp1(5, [0.0, 100.0], [0.03, 0.03], Type="G")  # structural damping g = 0.03: zeta 0.015
    model.add_tabdmp1(6, [0.0, 50.0, 100.0], [0.02, 0.01, 0.04], Type="CRIT")
    path = tmp_path / "flap.bdf"
    nd.finish_deck(model, path, case=["  SDAMP = 6"])
    assert wing_from_bdf(path).symmetry == "antisymmetric"  # AEROS SYMXZ = -1
    wing = wing_from_bdf(path, symmetry="symmetric", name="flap")
    pf = wing.planform
    assert (pf.root_chord, pf.tip_chord, pf.semispan, pf.n_chord, pf.n_span) == pytest.approx((0.4, 0.4, 1.0, 4, 5))
    assert wing.origin == (2.0, 1.0, 0.0) and wing.reference_chord == pytest.approx(0.35)
    assert wing.modal_damping == pytest.approx(0.01)  # SDAMP's CRIT table, its smallest ratio
    assert "TABDMP1 6 (CRIT), varying with frequency" in wing.description
    again = WingDefinition.from_dict(wing.to_dict())
    assert again == wing and again.structure is None
    with pytest.raises(ValueError, match="structure: wing 'flap' is planform-only"):
        wing.structure_for(None)
    assert WingDefinition.from_dict({**wing.to_dict(), "symmetry": "none"}).symmetry == "none"  # a free wing
    with pytest.raises(ValueError, match="symmetry: must be one of"):
        WingDefinition.from_dict({**wing.to_dict(), "symmetry": "mirrored"})
    del model.tables_sdamping[6]
    nd.finish_deck(model, path)  # no SDAMP, one table: g / 2
    assert wing_from_bdf(path, symmetry="symmetric").modal_damping == pytest.approx(0.015)


def test_cranked_planform_becomes_one_standard_mesh(tmp_path):
    """Several CAERO1 trapezoids with a bend in the leading edge and the chord: one planform with a kink where it
    bends (the two collinear outboard panels merge), the mesh's node rows through the kink, its nodes on the
    CAERO1 panels' edges and its area the panels' area."""
    from romams_core.mesh import standard_mesh

    wing = wing_from_bdf(nd.crank_deck(tmp_path / "crank.bdf"))
    pf = wing.planform
    assert wing.origin == (1.0, 0.5, 0.0)
    assert (pf.root_chord, pf.tip_chord, pf.semispan, pf.n_span) == pytest.approx((1.0, 0.5, 2.0, 10))
    np.testing.assert_allclose(pf.kinks, [(1.0, 0.1, 0.8)], rtol=1e-12)  # y, x_le, chord from the root LE
    assert "cranked planform: 1 kink(s)" in wing.description
    assert pf.area == pytest.approx(0.5 * (1.0 + 0.8) * 1.0 + 0.5 * (0.8 + 0.5) * 1.0, rel=1e-12)
    mesh = standard_mesh(pf)
    eta = mesh.eta
    assert np.sum(np.isclose(eta * pf.semispan, 1.0, atol=1e-12)) == 1  # a node row at the kink
    assert np.diff(eta[eta <= 0.5]).size == 5 and np.diff(eta[eta >= 0.5]).size == 5  # panels shared by span
    x, y = mesh.grid(mesh.x), mesh.grid(mesh.y)
    # leading and trailing edges of every node row on the deck's panel edges (exact linear interpolation)
    le_deck = np.interp(y[:, 0], [0.0, 1.0, 2.0], [0.0, 0.1, 0.6])
    te_deck = np.interp(y[:, 0], [0.0, 1.0, 2.0], [1.0, 0.9, 1.1])
    np.testing.assert_allclose(x[:, 0], le_deck, atol=1e-12)
    np.testing.assert_allclose(x[:, -1], te_deck, atol=1e-12)
    p = mesh.panels
    d1x, d1y = mesh.x[p[:, 2]] - mesh.x[p[:, 0]], mesh.y[p[:, 2]] - mesh.y[p[:, 0]]
    d2x, d2y = mesh.x[p[:, 3]] - mesh.x[p[:, 1]], mesh.y[p[:, 3]] - mesh.y[p[:, 1]]
    panel_area = 0.5 * np.abs(d1x * d2y - d1y * d2x)  # a quadrilateral's area from its diagonals
    assert panel_area.sum() == pytest.approx(pf.area, rel=1e-12)
    again = WingDefinition.from_dict(wing.to_dict())
    assert again == wing
    np.testing.assert_allclose(again.to_dict()["planform"]["kinks"], [[1.0, 0.1, 0.8]], rtol=1e-12)
    xi, eta_back = pf.to_xi_eta(mesh.x, mesh.y)  # the mapping inverts on the cranked planform too
    np.testing.assert_allclose(pf.to_xy(xi, eta_back), (mesh.x, mesh.y), atol=1e-12)


def test_cranked_planform_checks():
    """Kinks are validated by field; a built-in structure on a cranked planform is refused; a trapezoid's dict
    has no kinks key (stored wings are unchanged)."""
    from romams_core.mesh import Planform
    from romams_core.wing import template

    with pytest.raises(ValueError, match=r"planform.kinks\[0\].y: must be"):
        Planform(1.0, 0.5, 2.0, kinks=[(2.5, 0.1, 0.8)])
    with pytest.raises(ValueError, match=r"planform.kinks\[1\].y: kinks must be in increasing y"):
        Planform(1.0, 0.5, 2.0, kinks=[(1.0, 0.1, 0.8), (0.5, 0.1, 0.8)])
    with pytest.raises(ValueError, match=r"planform.kinks\[0\].chord"):
        Planform(1.0, 0.5, 2.0, kinks=[(1.0, 0.1, -0.8)])
    with pytest.raises(ValueError, match="planform.n_span: a planform with 2 kink"):
        Planform(1.0, 0.5, 2.0, n_span=2, kinks=[(0.5, 0.1, 0.9), (1.0, 0.2, 0.8)])
    base = template("cropped-delta").to_dict()
    assert "kinks" not in base["planform"]
    bad = {**base, "planform": {**base["planform"], "kinks": [[0.1, 0.05, 0.2]]}}
    with pytest.raises(ValueError, match="planform.kinks: the built-in plate and beam structures"):
        WingDefinition.from_dict(bad)


def test_includes_are_confined_and_messages_name_no_folder(tmp_path):
    deck = tmp_path / "deck"
    deck.mkdir()
    (deck / "main.bdf").write_text("SOL 103\nCEND\nBEGIN BULK\nINCLUDE 'grids.bdf'\nENDDATA\n")
    (deck / "grids.bdf").write_text("GRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\n")
    assert sorted(read_bdf(deck / "main.bdf", confine=True).nodes) == [1, 2]
    for bad in ("/etc/passwd", "../secret.bdf", "$HOME/x.bdf"):
        (deck / "main.bdf").write_text(f"SOL 103\nCEND\nBEGIN BULK\nINCLUDE '{bad}'\nENDDATA\n")
        with pytest.raises(ValueError, match="bdf: main.bdf: INCLUDE .* must name a file of the upload") as exc:
            read_bdf(deck / "main.bdf", confine=True)
        assert str(tmp_path) not in str(exc.value)
    (deck / "main.bdf").write_text("SOL 103\nCEND\nBEGIN BULK\nINCLUDE 'missing.bdf'\nENDDATA\n")
    with pytest.raises(ValueError, match="is not among the uploaded files"):
        read_bdf(deck / "main.bdf", confine=True)
    (deck / "main.bdf").write_text("SOL 103\nCEND\nBEGIN BULK\nGRID,1,,0.,0.,0.\nCQUAD4,1,1,1,2,3\nENDDATA\n")
    with pytest.raises(ValueError) as exc:
        load_modes_nastran(deck / "main.bdf", tmp_path / "nothing.op2")
    assert str(tmp_path) not in str(exc.value)
    assert scrub(f"cannot open {tmp_path}/romams-upload-x/model.bdf here") == "cannot open model.bdf here"


def test_splines_reproduce_exact_fields():
    """Beam spline: cubic bending and linear twist along a swept axis are exact between the nodes and off the
    axis (rigid sections); surface spline: a plane is exact everywhere, nodal values are returned at the nodes."""
    s_nodes = np.linspace(0.0, 1.0, 5)
    e = np.array([np.sin(0.3), np.cos(0.3)])  # swept axis direction (x aft, y span)
    b = np.array([e[1], -e[0]])  # in-plane normal pointing aft: (b x e)_z = 1
    axis = np.array([0.1, 0.0]) + s_nodes[:, None] * e
    theta = np.outer(e, 0.2 + 0.5 * s_nodes) + np.outer(b, 3 * s_nodes ** 2)  # twist about e, slope dw/ds = 3 s^2
    t, off = np.linspace(0.0, 1.0, 23), np.linspace(-0.2, 0.3, 23)
    targets = np.array([0.1, 0.0]) + t[:, None] * e + off[:, None] * b
    got = beam_spline(axis, (s_nodes ** 3)[:, None], theta[:, :, None], targets)[:, 0]
    np.testing.assert_allclose(got, t ** 3 - (0.2 + 0.5 * t) * off, atol=1e-12)  # (theta x off b)_z = -twist off
    rng = np.random.default_rng(3)
    pts = rng.uniform(0.0, 1.0, (40, 2))
    vals = np.column_stack([1.0 + 2.0 * pts[:, 0] - pts[:, 1], np.sin(3 * pts[:, 0]) * pts[:, 1]])
    tgt = rng.uniform(0.1, 0.9, (30, 2))
    np.testing.assert_allclose(surface_spline(pts, vals, tgt)[:, 0], 1.0 + 2.0 * tgt[:, 0] - tgt[:, 1], atol=1e-9)
    np.testing.assert_allclose(surface_spline(pts, vals, pts), vals, atol=1e-9)
