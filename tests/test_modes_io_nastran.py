"""Nastran BDF + OP2 (SOL 103) external modes through pyNastran, written and read back here.

Skipped only when pyNastran is not importable AND CI is not set (``make install`` installs it).
"""

from struct import Struct

import numpy as np
import pytest
from nastran_decks import BDF, OP2  # noqa: F401 (first: skips this module without pyNastran)
from pyNastran.op2.tables.lama_eigenvalues.lama_objects import RealEigenvalues
from pyNastran.op2.tables.oug.oug_eigenvectors import RealEigenvectorArray
from pyNastran.op2.writer.op2_writer import TrashWriter, write_op2_header

from romams_core.mesh import Planform, standard_mesh
from romams_core.modes_io import external_modal_result, load_modes_nastran

PLANFORM = Planform(root_chord=0.4, tip_chord=0.2, semispan=0.5, sweep_le=0.4, n_chord=6, n_span=8)
FREQS = np.array([12.5, 41.0, 77.0])
GEN_MASS = np.array([1.0, 4.0, 0.25])


def _rot_z(angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])  # rows: local axes in basic


def _plate():
    """GRIDs on the planform (9 x 7), their basic positions and analytic T3 per mode [P, 3]."""
    xi, eta = np.meshgrid(np.linspace(0, 1, 7), np.linspace(0, 1, 9))
    x, y = PLANFORM.to_xy(xi.ravel(), eta.ravel())
    xyz = np.column_stack([x, y, np.zeros_like(x)])
    w = np.column_stack([eta.ravel() ** 2, eta.ravel() * (xi.ravel() - 0.35), np.sin(3 * eta.ravel()) * xi.ravel()])
    return xyz, w


def _write_model(tmp_path, *, with_lama=True, bulk_only=True, freqs=FREQS):
    """Write plate.bdf (some GRIDs in a CP frame, some with a rotated CD frame) and modes.op2."""
    xyz, w = _plate()
    n = xyz.shape[0]
    nids = np.arange(101, 101 + n)
    origin = np.array([0.1, -0.2, 0.05])
    rot = _rot_z(0.7)
    model = BDF(debug=None)
    model.add_cord2r(1, origin, origin + rot[2], origin + rot[0])  # CP frame: translated and turned about z
    c, s = np.cos(0.5), np.sin(0.5)
    rot_cd = np.array([[1.0, 0.0, 0.0], [0.0, c, s], [0.0, -s, c]])  # CD frame turned about x: T2/T3 mix
    model.add_cord2r(2, [0.0, 0.0, 0.0], rot_cd[2], rot_cd[0])
    cp = (np.arange(n) % 3 == 1).astype(int)  # every third GRID given in frame 1
    cd = np.where(np.arange(n) % 4 == 2, 2, 0)  # every fourth GRID outputs in frame 2
    local = (xyz - origin) @ rot.T
    for i in range(n):
        model.add_grid(int(nids[i]), (local[i] if cp[i] else xyz[i]).tolist(), cp=int(cp[i]), cd=int(cd[i]))
    bdf_path = tmp_path / "plate.bdf"
    model.write_bdf(str(bdf_path), size=16)
    if not bulk_only:  # a complete SOL 103 input deck around the same bulk data
        bulk = [ln for ln in bdf_path.read_text().splitlines() if not ln.startswith("$")]
        deck = ["SOL 103", "CEND", "SUBCASE 1", "  METHOD = 1", "  DISP = ALL", "BEGIN BULK",
                "EIGRL          1                       4", *[ln for ln in bulk if ln.strip() != "ENDDATA"], "ENDDATA"]
        bdf_path.write_text("\n".join(deck) + "\n")

    k = freqs.size
    t_basic = np.zeros((k, n, 3))
    t_basic[:, :, 2] = (w * np.sqrt(GEN_MASS)).T  # not mass-normalized; LAMA carries the masses
    t_basic[:, :, 0] = 0.01 * t_basic[:, :, 2]  # some in-plane motion that must be ignored
    t_basic[:, :, 1] = -0.2 * t_basic[:, :, 2]
    t_out = t_basic.copy()
    sel = cd == 2
    t_out[:, sel, :] = t_basic[:, sel, :] @ rot_cd.T  # components in the CD frame
    data = np.zeros((k, n, 6), dtype="float32")
    data[:, :, :3] = t_out
    eigs = np.sign(freqs) * (2 * np.pi * freqs) ** 2
    modes = np.arange(1, k + 1)
    vec = RealEigenvectorArray.add_modal_case(
        "OUGV1", np.column_stack([nids, np.ones(n, dtype=int)]).astype("int32"), data, 1,
        modes, eigs, np.abs(freqs), is_sort1=True,
    )
    vec.table_code = 7  # eigenvector table (the generic helper sets 1 = displacement)
    vec.data_code["table_code"] = 7
    lama = RealEigenvalues("", "LAMA", nmodes=k)
    lama.mode[:] = modes
    lama.extraction_order[:] = modes
    lama.eigenvalues[:] = eigs
    lama.radians[:] = 2 * np.pi * np.abs(freqs)
    lama.cycles[:] = np.abs(freqs)
    lama.generalized_mass[:] = GEN_MASS
    lama.generalized_stiffness[:] = GEN_MASS * eigs
    # pyNastran 1.4.1's OP2.write_op2 skips LAMA tables, so the tables are written one by one
    op2 = OP2(debug=None)
    op2.set_mode("msc")
    s3, s9 = Struct(b"<3i"), Struct(b"<9i")
    op2_path = tmp_path / "modes.op2"
    with open(op2_path, "wb") as f:
        sink = TrashWriter()
        write_op2_header(op2, f, sink, s3, post=-1, endian=b"<")
        for table in ([lama] if with_lama else []) + [vec]:
            itable = table.write_op2(f, sink, -1, True, op2.date, is_mag_phase=False, endian=b"<")
            f.write(s9.pack(4, itable, 4, 4, 1, 4, 4, 0, 4))
            f.write(s3.pack(4, 0, 4))
        f.write(s3.pack(4, 0, 4))
    return bdf_path, op2_path, xyz, w


@pytest.mark.parametrize("bulk_only", [True, False])
def test_nastran_round_trip(tmp_path, bulk_only):
    bdf_path, op2_path, xyz, w = _write_model(tmp_path, bulk_only=bulk_only)
    m = load_modes_nastran(bdf_path, op2_path)
    np.testing.assert_allclose(m.nodes, xyz, atol=1e-9)  # CP frames resolved to basic
    np.testing.assert_allclose(m.frequencies_hz, FREQS, rtol=1e-6)  # float32 eigenvalues in the OP2
    np.testing.assert_allclose(m.generalized_masses, GEN_MASS, rtol=1e-6)
    np.testing.assert_allclose(m.shapes, w * np.sqrt(GEN_MASS), rtol=1e-5, atol=1e-7)  # CD frames rotated
    np.testing.assert_allclose(m.mass_normalized_shapes(), w, rtol=1e-5, atol=1e-7)
    assert m.source == "modes.op2"
    two = load_modes_nastran(bdf_path, op2_path, n_modes=2)
    assert two.n_modes == 2
    mesh = standard_mesh(PLANFORM)
    res = external_modal_result(m, mesh)
    xi, eta = PLANFORM.to_xi_eta(mesh.x, mesh.y)
    exact = np.column_stack([eta**2, eta * (xi - 0.35), np.sin(3 * eta) * xi])
    exact *= np.sign(exact[np.argmax(np.abs(exact), axis=0), [0, 1, 2]])
    assert np.max(np.abs(res.shapes - exact)) < 0.01 * np.abs(exact).max()


def test_nastran_without_lama_takes_vectors_as_mass_normalized(tmp_path):
    bdf_path, op2_path, _, w = _write_model(tmp_path, with_lama=False)
    m = load_modes_nastran(bdf_path, op2_path)
    assert m.generalized_masses is None
    np.testing.assert_allclose(m.frequencies_hz, FREQS, rtol=1e-6)
    np.testing.assert_allclose(m.mass_normalized_shapes(), w * np.sqrt(GEN_MASS), rtol=1e-5, atol=1e-7)


def test_nastran_errors(tmp_path):
    bdf_path, op2_path, _, _ = _write_model(tmp_path)
    with pytest.raises(ValueError, match="op2: file 'nope.op2' not found"):
        load_modes_nastran(bdf_path, tmp_path / "nope.op2")
    junk = tmp_path / "junk.op2"
    junk.write_bytes(b"\x00" * 64)
    with pytest.raises(ValueError, match="op2: cannot read junk.op2"):
        load_modes_nastran(bdf_path, junk)
    with pytest.raises(ValueError, match="subcase: 7 not in modes.op2"):
        load_modes_nastran(bdf_path, op2_path, subcase=7)
    with pytest.raises(ValueError, match="n_modes: must be in \\[1, 3\\]"):
        load_modes_nastran(bdf_path, op2_path, n_modes=5)
    few = BDF(debug=None)
    for nid in range(101, 111):
        few.add_grid(nid, [0.0, 0.01 * nid, 0.0])
    few_path = tmp_path / "few.bdf"
    few.write_bdf(str(few_path))
    with pytest.raises(ValueError, match="bdf: GRIDs \\[111, 112"):
        load_modes_nastran(few_path, op2_path)


def test_nastran_negative_eigenvalue_is_rejected(tmp_path):
    bdf_path, op2_path, _, _ = _write_model(tmp_path, freqs=np.array([-0.01, 41.0, 77.0]))
    with pytest.raises(ValueError, match="frequencies_hz: negative eigenvalues"):
        load_modes_nastran(bdf_path, op2_path)
