"""Import of a GAF table (a user's CFD or doublet-lattice forces on the wing's basis shapes) as a ROM: the one use
case behind ``romams train --gaf`` and ``POST /api/v1/wings/{wing}/roms/gaf``.

The table is fitted by the same rational function approximation as the built-in DLM's tables
(``romams_core.training_rfa.train_rfa_rom`` with a ``TableSolver``) and stored under the solver name
"external:<label>", one ROM per (wing, basis, Mach, label): importing again replaces it. A flutter request then
names that solver to use it.
"""

from __future__ import annotations

import hashlib
import re
from typing import Any

from romams.services.errors import InvalidInput, PayloadTooLarge
from romams.services.training import EXTERNAL_PREFIX, rom_identity
from romams_core.errors import InputError
from romams_core.gaf_table import GafTable, gaf_npz, read_gaf_csv, read_gaf_npz
from romams_core.mesh import standard_mesh

#: a label: letters, digits, "_", "-", "." (it becomes part of the solver name)
LABEL = re.compile(r"[A-Za-z0-9_.-]{1,40}")
#: largest table file accepted (bytes)
MAX_TABLE_BYTES = 32 << 20


def external_solver_name(label: str) -> str:
    """"external:<label>" for a valid label (InvalidInput naming ``label`` otherwise)."""
    if not isinstance(label, str) or LABEL.fullmatch(label) is None:
        raise InvalidInput("label", f"must be 1-40 letters, digits, '_', '-' or '.', got {label!r}")
    return EXTERNAL_PREFIX + label


def parse_table(data: bytes, filename: str = "", mach: float | None = None) -> GafTable:
    """A GAF table from the bytes of an NPZ or a CSV file (CSV: ``mach`` given apart); InvalidInput naming the
    field, PayloadTooLarge above MAX_TABLE_BYTES."""
    if len(data) > MAX_TABLE_BYTES:
        raise PayloadTooLarge("file", f"{len(data)} bytes; at most {MAX_TABLE_BYTES}")
    is_csv = filename.lower().endswith(".csv") or data.lstrip()[:12].lower().replace(b" ", b"") == b"k,row,col,re"
    if not (data.startswith(b"PK") or is_csv):
        raise InvalidInput("file", "neither an NPZ file (a zip) nor a CSV table with the header k,row,col,real,imag")
    try:
        if is_csv:
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


def import_table(store: Any, wing_id: int, wing: Any, basis_id: int, basis: Any, table: GafTable, label: str,
                 **fit: Any) -> tuple[int, Any]:
    """(rom_id, TrainedRfaRom): the RFA ROM of ``table`` (on the basis' shapes, in their order) stored as solver
    "external:<label>" at the table's Mach; ``fit``: n_lags, max_lags, fit_tol, reduce_order of the RFA."""
    from romams_core.gaf_table import TableSolver
    from romams_core.training_rfa import train_rfa_rom

    name = external_solver_name(label)
    if table.n_shapes != basis.n_basis:
        raise InvalidInput("gaf", f"the table has {table.n_shapes} shapes; basis {basis_id} has {basis.n_basis} "
                                  "(the table must be computed on the basis shapes, in their order)")
    digest = hashlib.sha256(gaf_npz(table)).hexdigest()[:16]
    solver = TableSolver(table, name=name, source=f"imported GAF table {label!r} (sha256 {digest})")
    try:
        rom = train_rfa_rom(standard_mesh(wing.planform), basis.shapes, table.mach, solver,
                            k_values=table.k_values, **fit)
    except InputError as exc:
        raise InvalidInput(exc.field, exc.reason) from None
    rid = store.roms.save(wing_id, basis_id, rom, rom_identity(name))
    return int(rid), rom
