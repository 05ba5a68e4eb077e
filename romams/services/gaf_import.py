"""Import of a GAF table (a user's CFD or doublet-lattice forces on the wing's basis shapes) as a ROM: the one use
case behind ``romams train --gaf`` and ``POST /api/v1/wings/{wing}/roms/gaf``.

The table is fitted by the same rational function approximation as the built-in DLM's tables
(``romams_core.training_rfa.train_rfa_rom`` with a ``TableSolver``) and stored under the solver name
"external:<label>", one ROM per (wing, basis, Mach, label): importing again replaces it. A flutter request then
names that solver to use it.

Files: NPZ, CSV (``romams_core.gaf_table``), and Nastran's QHH from an OUTPUT4 or a punch (DMIG) file
(``romams_core.nastran.qhh``), which needs the Mach number, the MKAERO1 k list and optionally the matrix name, the
Mach block, the leading modes to drop and REFC. REFC defaults to the wing's recorded one (a wing imported from a
Nastran deck), else to the wing's reference chord c_ref (no rescaling of k).
"""

from __future__ import annotations

import hashlib
import re
from dataclasses import replace
from typing import Any

from romams.services.errors import InvalidInput, PayloadTooLarge
from romams.services.training import EXTERNAL_PREFIX, rom_identity
from romams_core.errors import InputError
from romams_core.gaf_table import GafTable, gaf_npz, read_gaf_csv, read_gaf_npz
from romams_core.mesh import standard_mesh
from romams_core.nastran.qhh import QhhLayout, is_op4, is_punch, read_qhh_op4, read_qhh_punch

#: a label: letters, digits, "_", "-", "." (it becomes part of the solver name)
LABEL = re.compile(r"[A-Za-z0-9_.-]{1,40}")
#: largest table file accepted (bytes)
MAX_TABLE_BYTES = 32 << 20
#: the settings of a Nastran QHH file besides its Mach number (``romams_core.nastran.qhh.QhhLayout``)
QHH_FIELDS = ("k_values", "matrix", "mach_index", "skip_modes", "refc")
#: file-name endings of a punch file
PUNCH_SUFFIXES = (".pch", ".pun", ".punch")


def external_solver_name(label: str) -> str:
    """"external:<label>" for a valid label (InvalidInput naming ``label`` otherwise)."""
    if not isinstance(label, str) or LABEL.fullmatch(label) is None:
        raise InvalidInput("label", f"must be 1-40 letters, digits, '_', '-' or '.', got {label!r}")
    return EXTERNAL_PREFIX + label


def parse_k_list(text: str) -> list[float]:
    """Reduced frequencies (dimensionless) from text: numbers separated by commas and/or spaces (InvalidInput naming
    ``k_values``)."""
    parts = [p for p in re.split(r"[,\s]+", str(text).strip().strip("[]")) if p]
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise InvalidInput("k_values", f"must be numbers separated by commas, got {str(text)[:40]!r}") from None
    if not values:
        raise InvalidInput("k_values", "give the MKAERO1 reduced frequencies, e.g. 0.001,0.05,0.1,0.2")
    return values


def table_kind(data: bytes, filename: str = "") -> str:
    """'npz', 'csv', 'op4' or 'punch' by the file's content and name (InvalidInput naming ``file`` otherwise)."""
    name = filename.lower()
    if data.startswith(b"PK"):
        return "npz"
    if name.endswith(".csv") or data.lstrip()[:12].lower().replace(b" ", b"") == b"k,row,col,re":
        return "csv"
    if name.endswith(".op4") or is_op4(data):
        return "op4"
    if name.endswith(PUNCH_SUFFIXES) or is_punch(data):
        return "punch"
    raise InvalidInput("file", "neither an NPZ file (a zip), a CSV table with the header k,row,col,real,imag, a "
                               "Nastran OUTPUT4 file nor a punch file with DMIG cards")


def parse_table(data: bytes, filename: str = "", mach: float | None = None, qhh: dict[str, Any] | None = None,
                wing: Any = None) -> GafTable:
    """A GAF table from the bytes of an NPZ, CSV, OUTPUT4 or punch file (CSV, OP4, punch: ``mach`` given apart;
    OP4, punch: ``qhh`` the QHH_FIELDS given, ``wing`` for its reference chords); InvalidInput naming the field,
    PayloadTooLarge above MAX_TABLE_BYTES. ImportError when a Nastran file comes and pyNastran is missing."""
    if len(data) > MAX_TABLE_BYTES:
        raise PayloadTooLarge("file", f"{len(data)} bytes; at most {MAX_TABLE_BYTES}")
    kind = table_kind(data, filename)
    given = {k: v for k, v in (qhh or {}).items() if v is not None}
    try:
        if kind in ("op4", "punch"):
            return _parse_qhh(data, kind, mach, given, wing)
        if given:
            raise InvalidInput(sorted(given)[0], "applies to a Nastran QHH file (OUTPUT4 or punch) only")
        if kind == "csv":
            if mach is None:
                raise InvalidInput("mach", "a CSV table needs its Mach number")
            try:
                text = data.decode("utf-8")
            except UnicodeDecodeError:
                raise InvalidInput("file", "a CSV table must be UTF-8 text") from None
            return read_gaf_csv(text, mach)
        table = read_gaf_npz(data)
    except InputError as exc:
        raise InvalidInput(exc.field, exc.reason) from None
    if mach is not None and abs(float(mach) - table.mach) > 1e-9:
        raise InvalidInput("mach", f"the table is at M {table.mach:g}, the request says {mach:g}")
    return table


def _parse_qhh(data: bytes, kind: str, mach: float | None, given: dict[str, Any], wing: Any) -> GafTable:
    """The table of a Nastran QHH file (``kind`` 'op4' or 'punch'); REFC defaults to the wing's recorded one."""
    if mach is None:
        raise InvalidInput("mach", "a Nastran QHH file holds no Mach number: give the one of its Mach block")
    if "k_values" not in given:
        raise InvalidInput("k_values", "a Nastran QHH file holds no reduced frequencies: give the MKAERO1 k list "
                                       "(Nastran's k, on REFC/2)")
    layout = QhhLayout(**given)
    c_ref = None if wing is None else float(wing.planform.c_ref)
    if layout.refc is None and getattr(wing, "reference_chord", None):
        layout = replace(layout, refc=float(wing.reference_chord))
    reader = read_qhh_op4 if kind == "op4" else read_qhh_punch
    return reader(data, mach, layout, c_ref)


def import_table(store: Any, wing_id: int, wing: Any, basis_id: int, basis: Any, table: GafTable, label: str,
                 **fit: Any) -> tuple[int, Any]:
    """(rom_id, TrainedRfaRom): the RFA ROM of ``table`` (on the basis' shapes, in their order) stored as solver
    "external:<label>" at the table's Mach; ``fit``: n_lags, max_lags, fit_tol, reduce_order of the RFA."""
    from romams_core.gaf_table import TableSolver
    from romams_core.training_rfa import train_rfa_rom

    name = external_solver_name(label)
    if table.n_shapes != basis.n_basis:
        nastran = table.source.startswith("Nastran")
        hint = "; drop a Nastran QHH's other leading modes with skip_modes" if nastran else ""
        raise InvalidInput("gaf", f"the table has {table.n_shapes} shapes; basis {basis_id} has {basis.n_basis} "
                                  f"(the table must be computed on the basis shapes, in their order{hint})")
    digest = hashlib.sha256(gaf_npz(table)).hexdigest()[:16]
    origin = f" from {table.source}" if table.source else ""
    solver = TableSolver(table, name=name, source=f"imported GAF table {label!r}{origin} (sha256 {digest})")
    try:
        rom = train_rfa_rom(standard_mesh(wing.planform), basis.shapes, table.mach, solver,
                            k_values=table.k_values, **fit)
    except InputError as exc:
        raise InvalidInput(exc.field, exc.reason) from None
    rid = store.roms.save(wing_id, basis_id, rom, rom_identity(name))
    return int(rid), rom
