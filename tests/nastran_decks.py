"""Nastran decks and OP2 files for the tests, written with pyNastran from modes computed here.

There is no Nastran executable: the plate's modes come from the project's own plate FE (DKT), the stick
model's from a small numpy beam FE; their eigenvectors are written as SOL 103 OP2 tables by pyNastran.
"""

from __future__ import annotations

import os
from struct import Struct, pack

import numpy as np
import pytest
import scipy.linalg

from romams_core.modes_io import _import_pynastran

try:
    BDF, OP2 = _import_pynastran()
except ImportError:  # the importing test module is skipped, except under CI (pyNastran is part of `make install`)
    if os.environ.get("CI", "").lower() in ("1", "true", "yes"):
        raise
    pytest.skip("pyNastran not installed (it is required under CI)", allow_module_level=True)

from pyNastran.bdf.case_control_deck import CaseControlDeck  # noqa: E402
from pyNastran.op2.tables.lama_eigenvalues.lama_objects import (  # noqa: E402
    ComplexEigenvalues,
    RealEigenvalues,
    _write_table_header,
)
from pyNastran.op2.tables.oug.oug_eigenvectors import RealEigenvectorArray  # noqa: E402
from pyNastran.op2.writer.op2_writer import TrashWriter, write_op2_header  # noqa: E402


def eigenvector_table(nids, data, freqs, subcase=1):
    """A SOL 103 eigenvector table (OUGV1) of GRIDs ``nids`` with T1..R3 ``data`` [k, n, 6]."""
    k, n = data.shape[0], len(nids)
    eigs = np.sign(freqs) * (2 * np.pi * freqs) ** 2
    vec = RealEigenvectorArray.add_modal_case(
        "OUGV1", np.column_stack([nids, np.ones(n, dtype=int)]).astype("int32"), data.astype("float32"), subcase,
        np.arange(1, k + 1), eigs, np.abs(freqs), is_sort1=True)
    vec.table_code = 7  # eigenvector table (the generic helper sets 1 = displacement)
    vec.data_code["table_code"] = 7
    return vec


def real_eigenvalues(freqs, gen_mass):
    """A LAMA table (frequencies in Hz, generalized masses)."""
    k = len(freqs)
    eigs = np.sign(freqs) * (2 * np.pi * freqs) ** 2
    lama = RealEigenvalues("", "LAMA", nmodes=k)
    lama.mode[:] = lama.extraction_order[:] = np.arange(1, k + 1)
    lama.eigenvalues[:] = eigs
    lama.radians[:] = 2 * np.pi * np.abs(freqs)
    lama.cycles[:] = np.abs(freqs)
    lama.generalized_mass[:] = gen_mass
    lama.generalized_stiffness[:] = np.asarray(gen_mass) * eigs
    return lama


class _Clama(ComplexEigenvalues):
    """pyNastran 1.4.1's CLAMA writer declares 7 words per mode and writes 6; this one declares 6."""

    def write_op2(self, op2_file, op2_ascii, itable, new_result, date, is_mag_phase=False, endian=b">"):
        if itable == -1:
            _write_table_header(self.table_name, op2_file, op2_ascii, date)
            itable = -3
        self._write_table_3(op2_file, op2_ascii, new_result, itable, 0)
        itable -= 1
        ntotal = 6 * len(self.mode)
        op2_file.write(pack(b"<13i", 4, itable, 4, 4, 1, 4, 4, 0, 4, 4, ntotal, 4, 4 * ntotal))
        row = Struct(endian + b"ii4f")
        for i, mode in enumerate(self.mode):
            ev = self.eigenvalues[i]
            op2_file.write(row.pack(int(mode), int(self.extraction_order[i]), ev.real, ev.imag,
                                    float(self.cycles[i]), float(self.damping[i])))
        op2_file.write(pack(b"<i", 4 * ntotal))
        return itable - 1


def flutter_eigenvalues():
    """A CLAMA table as a SOL 145 run writes it (complex eigenvalues, no generalized masses)."""
    clama = _Clama("FLUTTER", "CLAMA", nmodes=2)
    clama.mode[:] = clama.extraction_order[:] = [1, 2]
    clama.eigenvalues[:] = [-1.0 + 60.0j, -3.0 + 250.0j]
    clama.cycles[:] = [9.5, 39.8]
    clama.damping[:] = [-0.03, -0.02]
    return clama


def write_tables(path, tables):
    """Write OP2 tables one by one (pyNastran 1.4.1's OP2.write_op2 skips LAMA and refuses CLAMA)."""
    op2 = OP2(debug=None)
    op2.set_mode("msc")
    s3, s9 = Struct(b"<3i"), Struct(b"<9i")
    with open(path, "wb") as f:
        sink = TrashWriter()
        write_op2_header(op2, f, sink, s3, post=-1, endian=b"<")
        for table in tables:
            itable = table.write_op2(f, sink, -1, True, op2.date, is_mag_phase=False, endian=b"<")
            f.write(s9.pack(4, itable, 4, 4, 1, 4, 4, 0, 4))
            f.write(s3.pack(4, 0, 4))
        f.write(s3.pack(4, 0, 4))
    return path


def write_op2(path, vec):
    """Write an eigenvector table through pyNastran's OP2 writer (``OP2.write_op2``)."""
    op2 = OP2(debug=None)
    op2.set_mode("msc")
    op2.eigenvectors[1] = vec
    op2.write_op2(str(path))
    return path


def add_caero(model, planform, origin, *, split=0.5, sym_xz=1, cref=None, nspans=(4, 4), nchord=6):
    """Two CAERO1 panels (root..split with NSPAN, split..tip with an AEFACT list of LSPAN) on ``planform`` moved
    by ``origin``; ``nchord`` chordwise boxes; AERO card."""
    origin = np.asarray(origin, dtype=float)
    model.add_paero1(1000)
    model.add_aefact(90, np.linspace(0.0, 1.0, nspans[1] + 1).tolist())
    etas = [0.0, split, 1.0]
    for i in range(2):
        x1, y1 = planform.to_xy(0.0, etas[i])
        x4, y4 = planform.to_xy(0.0, etas[i + 1])
        c1, c4 = float(planform.chord(y1)), float(planform.chord(y4))
        nspan, lspan = (0, 90) if i == 1 else (nspans[0], 0)
        model.add_caero1(1001 + 100 * i, 1000, 1, origin + [float(x1), float(y1), 0.0], c1,
                         origin + [float(x4), float(y4), 0.0], c4, nspan=nspan, lspan=lspan, nchord=nchord)
    model.add_aero(velocity=100.0, cref=cref or planform.root_chord, rho_ref=1.225, sym_xz=sym_xz)


def finish_deck(model, path, spc_nodes=(), case=()):
    """A SOL 103 deck: case control (METHOD, SPC, DISP and ``case`` lines), EIGRL, root SPC; written to ``path``."""
    model.sol = 103
    model.case_control_deck = CaseControlDeck(["SUBCASE 1", "  METHOD = 1", "  SPC = 1", "  DISP = ALL",
                                               *case, "BEGIN BULK"])
    model.add_eigrl(1, nd=4)
    if len(spc_nodes):
        model.add_spc1(1, "123456", [int(n) for n in spc_nodes])
    model.write_bdf(str(path), size=16)
    return path


def plate_deck(tmp_path, wing, modal, origin, *, sym_xz=1):
    """BDF of a plate wing: GRIDs at the FE nodes + origin, CTRIA3s, PSHELL/MAT1, root SPC, CAERO1s, AERO."""
    model = BDF(debug=None)
    xy = modal.fe_xy
    nids = np.arange(1, xy.shape[0] + 1)
    for nid, (x, y) in zip(nids, xy, strict=True):
        model.add_grid(int(nid), (np.array([x, y, 0.0]) + origin).tolist())
    for eid, tri in enumerate(modal.fe_triangles, start=1):
        model.add_ctria3(eid, 1, [int(n) for n in nids[tri]])
    mat = wing.structure.material
    model.add_mat1(1, mat.E1, None, mat.nu12, rho=mat.density)
    model.add_pshell(1, mid1=1, t=wing.structure.thickness, mid2=1)
    add_caero(model, wing.planform, origin, sym_xz=sym_xz)
    root = nids[np.abs(xy[:, 1]) < 1e-12]
    return finish_deck(model, tmp_path / "plate.bdf", root), nids


def beam_modes(n_el=10, semispan=0.5, ei=80.0, gj=60.0, m=1.2, i_t=4e-3, s=0.01, n_modes=4):
    """Cantilever bending-torsion beam along +y (numpy FE): y [n], frequencies [k] Hz, and per node w, dw/dy and
    twist theta_y [3, n, k] (mass-normalized; DOFs w, theta_x = dw/dy, theta_y with w = -theta_y (x - x_axis))."""
    n = n_el + 1
    le = semispan / n_el
    kb = ei / le ** 3 * np.array([[12, 6 * le, -12, 6 * le], [6 * le, 4 * le ** 2, -6 * le, 2 * le ** 2],
                                  [-12, -6 * le, 12, -6 * le], [6 * le, 2 * le ** 2, -6 * le, 4 * le ** 2]])
    mb = m * le / 420 * np.array([[156, 22 * le, 54, -13 * le], [22 * le, 4 * le ** 2, 13 * le, -3 * le ** 2],
                                  [54, 13 * le, 156, -22 * le], [-13 * le, -3 * le ** 2, -22 * le, 4 * le ** 2]])
    kt = gj / le * np.array([[1, -1], [-1, 1]])
    mt = i_t * le / 6 * np.array([[2, 1], [1, 2]])
    K, M = np.zeros((3 * n, 3 * n)), np.zeros((3 * n, 3 * n))
    for e in range(n_el):
        b = [3 * e, 3 * e + 1, 3 * e + 3, 3 * e + 4]
        t = [3 * e + 2, 3 * e + 5]
        K[np.ix_(b, b)] += kb
        M[np.ix_(b, b)] += mb
        K[np.ix_(t, t)] += kt
        M[np.ix_(t, t)] += mt
        for a in range(2):  # lumped static-unbalance coupling w - theta_y (CG aft of the axis by s / m)
            M[3 * (e + a), 3 * (e + a) + 2] += -0.5 * s * le
            M[3 * (e + a) + 2, 3 * (e + a)] += -0.5 * s * le
    free = np.arange(3, 3 * n)
    lam, vec = scipy.linalg.eigh(K[np.ix_(free, free)], M[np.ix_(free, free)])
    phi = np.zeros((3 * n, n_modes))
    phi[free] = vec[:, :n_modes]
    return np.linspace(0.0, semispan, n), np.sqrt(lam[:n_modes]) / (2 * np.pi), phi.reshape(n, 3, n_modes)


STICK_X = 0.15  # the beam axis: mid-chord of STICK_PLANFORM


def stick_deck(folder, planform, *, n_el=10, sym_xz=1):
    """A CBAR stick model on the axis x = STICK_X (GRIDs, CBAR/PBAR/MAT1, root SPC, CAERO1s, AERO) and its SOL 103
    OP2 (T3, R1, R2 from :func:`beam_modes`); returns (bdf, op2, y, phi)."""
    y, freqs, phi = beam_modes(n_el=n_el, semispan=planform.semispan)
    model = BDF(debug=None)
    nids = np.arange(1, y.size + 1)
    for nid, yy in zip(nids, y, strict=True):
        model.add_grid(int(nid), [STICK_X, float(yy), 0.0])
    model.add_mat1(1, 70e9, None, 0.3, rho=2700.0)
    model.add_pbar(1, 1, A=1e-4, i1=1e-9, i2=1e-9, j=1e-9)
    for e in range(y.size - 1):
        model.add_cbar(e + 1, 1, [int(nids[e]), int(nids[e + 1])], [1.0, 0.0, 0.0], None)
    half = planform.n_span // 2
    add_caero(model, planform, [0.0, 0.0, 0.0], nspans=(half, planform.n_span - half), sym_xz=sym_xz,
              nchord=planform.n_chord)
    bdf = finish_deck(model, folder / "stick.bdf", nids[:1])
    data = np.zeros((freqs.size, y.size, 6))
    data[:, :, 2] = phi[:, 0].T  # T3 = w
    data[:, :, 3] = phi[:, 1].T  # R1 = dw/dy
    data[:, :, 4] = phi[:, 2].T  # R2 = twist about y
    op2 = write_op2(folder / "stick.op2", eigenvector_table(nids, data, freqs))
    return bdf, op2, y, phi


def crank_deck(path, nspan=(4, 6)):
    """A cranked wing of three CAERO1s: inboard trapezoid, then two outboard panels on one straight trapezoid."""
    crank = BDF(debug=None)
    crank.add_paero1(1)
    crank.add_caero1(1, 1, 1, [1.0, 0.5, 0.0], 1.0, [1.1, 1.5, 0.0], 0.8, nspan=nspan[0], nchord=4)
    crank.add_caero1(2, 1, 1, [1.1, 1.5, 0.0], 0.8, [1.35, 2.0, 0.0], 0.65, nspan=nspan[1] // 2, nchord=4)
    crank.add_caero1(3, 1, 1, [1.35, 2.0, 0.0], 0.65, [1.6, 2.5, 0.0], 0.5, nspan=nspan[1] // 2, nchord=4)
    finish_deck(crank, path)
    return path
