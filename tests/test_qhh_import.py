"""Nastran QHH as a GAF table (romams_core.nastran.qhh): the DLM's own table written in Nastran's layouts (ASCII
OUTPUT4 through pyNastran's writer, binary OUTPUT4 records, DMIG punch cards) and read back gives the DLM ROM's
flutter point; malformed files and settings are refused naming the field."""

from __future__ import annotations

import io
import struct
import tempfile

import numpy as np
import pytest
from fast_settings import baseline_dlm_rom

from romams_core.errors import InputError
from romams_core.flutter import flutter_analysis
from romams_core.gaf_table import GafTable, TableSolver
from romams_core.nastran.qhh import QhhLayout, is_op4, is_punch, read_qhh_op4, read_qhh_punch
from romams_core.training_rfa import train_rfa_rom

MACH = 0.87


@pytest.fixture(scope="module")
def dlm():
    """Cropped delta, baseline 4 modes, the DLM ROM (one box per panel), its table and flutter point."""
    wing, mesh, modal, rom = baseline_dlm_rom(MACH)
    ref = flutter_analysis(modal.omega, rom.ss, rom.c_ref, MACH, zeta=wing.modal_damping)
    assert ref.flutter_found
    return wing, mesh, modal, GafTable(MACH, rom.k_values, rom.gaf), ref


def wide(blocks: np.ndarray) -> np.ndarray:
    """Nastran's list layout of blocks [n, h, h]: one h x (h n) matrix, the blocks side by side."""
    return np.hstack(list(blocks))


def op4_ascii(matrices: list[np.ndarray], name: str = "QHH") -> bytes:
    """An ASCII OUTPUT4 of the matrices (one after the other, all called ``name``) by pyNastran's writer."""
    from pyNastran.op4.op4 import write_op4

    out = io.StringIO()
    for m in matrices:
        write_op4(out, {name: (2, m)}, is_binary=False, precision="double")
    return out.getvalue().encode()


def op4_binary(matrices: list[np.ndarray], name: str = "QHH") -> bytes:
    """A binary (little-endian) OUTPUT4 of complex double matrices: Fortran records of the header, one per column
    and the closing column (pyNastran 1.4.1's binary writer packs the column header as doubles, so not used)."""

    def record(payload: bytes) -> bytes:
        """One Fortran record: its length in bytes, the payload, the length again."""
        n = struct.pack("<i", len(payload))
        return n + payload + n

    out = []
    for m in matrices:
        nrows, ncols = m.shape
        out.append(record(struct.pack("<4i8s", ncols, nrows, 2, 4, name.ljust(8).encode())))
        for j in range(ncols):
            values = np.column_stack([m[:, j].real, m[:, j].imag]).astype("<f8").tobytes()
            out.append(record(struct.pack("<3i", j + 1, 1, 4 * nrows) + values))
        out.append(record(struct.pack("<3i", ncols + 1, 1, 2) + struct.pack("<d", 1.0)))
    return b"".join(out)


def punch(matrix: np.ndarray, name: str = "QHH") -> bytes:
    """A punch file of DMIG cards (large field, as Nastran punches them) by pyNastran's card writer: rows on
    scalar points 1..h, columns on 101..100 + n."""
    from romams_core.nastran.deck import import_pynastran

    BDF, _ = import_pynastran()
    model = BDF(debug=None)
    rows, cols = np.meshgrid(np.arange(matrix.shape[0]), np.arange(matrix.shape[1]), indexing="ij")
    gcj = [(101 + int(j), 0) for j in cols.T.ravel()]
    gci = [(1 + int(i), 0) for i in rows.T.ravel()]
    values = matrix.T.ravel()
    model.add_dmig(name, 9, 4, 4, 0, matrix.shape[1], gcj, gci, values.real.tolist(), values.imag.tolist())
    out = io.StringIO()
    model.write_bdf(out, size=16, is_double=True, close=False, write_header=False)
    return ("$ punched by a test\n" + out.getvalue()).encode()


def flutter_of(dlm, table: GafTable):
    """The flutter point of the ROM fitted to ``table`` on the modes of ``dlm``."""
    wing, mesh, modal, _, _ = dlm
    rom = train_rfa_rom(mesh, modal.shapes, MACH, TableSolver(table, name="external:nastran"), k_values=table.k_values)
    return flutter_analysis(modal.omega, rom.ss, rom.c_ref, MACH, zeta=wing.modal_damping)


def test_qhh_files_in_nastran_layouts_give_the_dlm_flutter_point(dlm):
    _, mesh, _, table, ref = dlm
    k, h = table.k_values, table.gaf
    nk = k.size
    padded = np.zeros((nk, 5, 5), dtype=complex)  # a leading extra mode (row and column 0) to skip
    padded[:, 0, :] = 1.0 + 2.0j
    padded[:, :, 0] = -3.0 + 0.5j
    padded[:, 1:, 1:] = h
    other_mach = 0.5 * padded  # a first Mach block the reader must pass over
    refc = 2.0 * mesh.c_ref
    cases = {
        # one wide matrix (the list layout), pyNastran's ASCII writer
        "ascii wide": (read_qhh_op4, op4_ascii([wide(h)]), QhhLayout(tuple(k)), None),
        # one h x h matrix per m-k pair, two Machs, the k list in descending order, a leading mode to drop
        "binary per pair": (read_qhh_op4, op4_binary([*other_mach[::-1], *padded[::-1]]),
                            QhhLayout(tuple(k[::-1]), mach_index=1, skip_modes=1), None),
        # Nastran's k on REFC/2 = 2 c_ref / 2: k_nastran = 2 k (exact in binary, so the table's k are the DLM's)
        "ascii refc": (read_qhh_op4, op4_ascii([wide(h)]), QhhLayout(tuple(2.0 * k), refc=refc), mesh.c_ref),
        "punch": (read_qhh_punch, punch(wide(h)), QhhLayout(tuple(k)), None),
    }
    for case, (reader, data, layout, c_ref) in cases.items():
        got = reader(data, MACH, layout, c_ref)
        np.testing.assert_array_equal(got.k_values, k, err_msg=case)
        exact = case != "punch"  # a punch file's large fields hold 10 significant digits
        np.testing.assert_allclose(got.gaf, h, rtol=0 if exact else 1e-9, atol=0 if exact else 1e-12, err_msg=case)
        assert got.source.startswith("Nastran QHH")
        r = flutter_of(dlm, got)
        assert r.flutter_mode == ref.flutter_mode, case
        # the issue asks 0.1 %; the punch's 2e-10 rounding of H moves the flutter point by about 1e-9
        rel = 1e-9 if exact else 1e-8
        assert r.q_flutter_pa == pytest.approx(ref.q_flutter_pa, rel=rel), case
        assert r.omega_flutter_rad_s == pytest.approx(ref.omega_flutter_rad_s, rel=rel), case
    assert is_op4(cases["ascii wide"][1]) and is_op4(cases["binary per pair"][1]) and is_punch(cases["punch"][1])
    assert not is_op4(cases["punch"][1]) and not is_punch(b"k,row,col,real,imag\n")


def test_malformed_qhh_files_and_settings_name_the_field(dlm):
    table = dlm[3]
    k, h = tuple(table.k_values), table.gaf
    good = op4_ascii([wide(h)])
    nan = h.copy()
    nan[3, 1, 2] = np.nan
    cases = [
        (lambda: read_qhh_op4(good, MACH, QhhLayout(k, matrix="QHHL")), "matrix"),
        (lambda: read_qhh_op4(good, MACH, QhhLayout(k[:-1])), "k_values"),  # 16 blocks, 15 k
        (lambda: read_qhh_op4(good, MACH, QhhLayout(k, mach_index=1)), "mach_index"),
        (lambda: read_qhh_op4(good, MACH, QhhLayout(k, skip_modes=4)), "skip_modes"),
        (lambda: read_qhh_op4(good, 1.2, QhhLayout(k)), "mach"),
        (lambda: read_qhh_op4(op4_binary([wide(nan)]), MACH, QhhLayout(k)), "gaf"),
        (lambda: read_qhh_op4(op4_ascii([wide(nan)]), MACH, QhhLayout(k)), "gaf"),  # pyNastran would misread it
        (lambda: read_qhh_op4(op4_ascii([wide(h)[:, :-1]]), MACH, QhhLayout(k)), "matrix"),  # 63 columns
        (lambda: read_qhh_op4(good[: len(good) // 2], MACH, QhhLayout(k)), "file"),  # cut short
        (lambda: read_qhh_op4(b"not an OP4 file", MACH, QhhLayout(k)), "file"),
        (lambda: read_qhh_punch(punch(wide(h)), MACH, QhhLayout(k, matrix="KHH")), "matrix"),
        (lambda: read_qhh_punch(b"INCLUDE '/etc/passwd'\n" + punch(wide(h)), MACH, QhhLayout(k)), "file"),
        (lambda: read_qhh_op4(good, MACH, QhhLayout(k, refc=1.0)), "refc"),  # no c_ref to rescale to
        (lambda: QhhLayout(()), "k_values"),
        (lambda: QhhLayout((0.1, 0.1, 0.2, 0.3)), "k_values"),
        (lambda: QhhLayout((0.1, float("nan"))), "k_values"),
        (lambda: QhhLayout(k, matrix="Q H"), "matrix"),
        (lambda: QhhLayout(k, mach_index=-1), "mach_index"),
        (lambda: QhhLayout(k, refc=0.0), "refc"),
    ]
    for call, field in cases:
        with pytest.raises(InputError) as e:
            call()
        assert e.value.field == field, (field, e.value)
        assert tempfile.gettempdir() not in str(e.value) and "romams-op4" not in str(e.value)


def test_parse_table_recognises_nastran_files_and_needs_their_settings(dlm):
    """The service's file sniffing: OP4 and punch by content or name; the Mach and the k list are required, QHH
    settings on an NPZ are refused, REFC defaults to the wing's recorded one."""
    from dataclasses import replace

    from romams.services.errors import InvalidInput
    from romams.services.gaf_import import parse_k_list, parse_table
    from romams_core.gaf_table import gaf_npz

    wing, mesh, _, table, _ = dlm
    k = table.k_values
    data = op4_binary([wide(table.gaf)])
    got = parse_table(data, "upload.bin", MACH, {"k_values": parse_k_list(",".join(repr(float(x)) for x in k))}, wing)
    np.testing.assert_array_equal(got.gaf, table.gaf)
    pch = parse_table(punch(wide(table.gaf)), "qhh.pch", MACH, {"k_values": list(k), "matrix": "qhh"}, wing)
    np.testing.assert_allclose(pch.gaf, table.gaf, rtol=1e-9, atol=1e-12)
    # a wing imported from a deck with AERO REFC = c_ref / 4: Nastran's k is a quarter of ours
    deck_wing = replace(wing, reference_chord=mesh.c_ref / 4)
    scaled = parse_table(data, "qhh.op4", MACH, {"k_values": list(k / 4)}, deck_wing)
    np.testing.assert_allclose(scaled.k_values, k, rtol=1e-15)
    assert "c_ref / REFC" in scaled.source
    for args, field in (((data, "qhh.op4", None, {"k_values": list(k)}), "mach"),
                        ((data, "qhh.op4", MACH, None), "k_values"),
                        ((data, "qhh.op4", MACH, {"matrix": "QHH"}), "k_values"),
                        ((gaf_npz(table), "t.npz", None, {"k_values": [0.1]}), "k_values"),
                        ((b"junk", "t.dat", None, None), "file")):
        with pytest.raises(InvalidInput) as e:
            parse_table(*args, wing=wing)
        assert e.value.field == field, (field, e.value)
    for text in ("", "0.1,,x", "a b"):
        with pytest.raises(InvalidInput) as e:
            parse_k_list(text)
        assert e.value.field == "k_values"
    assert parse_k_list("[0, 0.1 0.2,0.5]") == [0.0, 0.1, 0.2, 0.5]
