"""Generalized aerodynamic force tables computed elsewhere (a user's CFD or doublet-lattice code, Nastran's QHH)
as a frequency-domain solver, so that they become rational-function ROMs exactly as the built-in DLM's do.

A table holds, at one Mach number, the complex GAC matrix H [nk, m, m] (m^3 per unit generalized displacement)
at reduced frequencies k [nk] on the semichord b = c_ref / 2, with the conventions of
``romams_core.aero.protocol``: H[k, i, j] is f_i = (1/q) * integral(dp * phi_i dS) for a unit harmonic motion
u_j, dp positive up, the shapes phi_j the wing's basis shapes (out-of-plane displacement, m). The columns must be
the basis shapes in the basis' order: the table cannot be checked against them, only its size can.

File formats (``read_gaf_npz``, ``read_gaf_csv``; ``gaf_npz`` writes the first):
- NPZ: ``k`` [nk], ``gaf_real`` and ``gaf_imag`` [nk, m, m] (or one complex ``gaf``), ``mach`` (a scalar);
- CSV: header ``k,row,col,real,imag``, one line per entry (rows and columns from 0), the Mach number given apart;
- Nastran's QHH from an OUTPUT4 or a punch file: ``romams_core.nastran.qhh`` (the Mach and k list given apart).
"""

from __future__ import annotations

import csv
import io
import zipfile
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from romams_core.aero.protocol import ProgressFn, SolverInfo, check_k_values, check_mach
from romams_core.errors import InputError
from romams_core.mesh import StandardMesh

#: largest table accepted (entries nk * m * m)
MAX_ENTRIES = 2_000_000
#: the CSV header
CSV_COLUMNS = ("k", "row", "col", "real", "imag")


@dataclass(frozen=True)
class GafTable:
    """GAC matrices H [nk, m, m] (m^3, complex) at reduced frequencies k [nk] (semichord) and one Mach number;
    ``source``: where it came from, when a reader knows more than the caller (e.g. a Nastran QHH's layout)."""

    mach: float
    k_values: np.ndarray
    gaf: np.ndarray
    source: str = ""

    @property
    def n_shapes(self) -> int:
        """Number of shapes m (rows = columns)."""
        return int(self.gaf.shape[1])


def check_table(mach: Any, k_values: Any, gaf: Any) -> GafTable:
    """A validated table (InputError naming ``mach``, ``k_values`` or ``gaf``): 0 <= M < 1, k as the RFA needs
    (finite, >= 0, strictly ascending, at least 4), H [nk, m, m] finite with nk = len(k)."""
    m = check_mach(mach, upper=1.0)
    k = check_k_values(k_values)
    if k.size < 4:
        raise InputError("k_values", f"need at least 4 reduced frequencies for the RFA, got {k.size}")
    try:
        h = np.asarray(gaf, dtype=complex)
    except (TypeError, ValueError):
        raise InputError("gaf", "must be an array of numbers") from None
    if h.ndim != 3 or h.shape[0] != k.size or h.shape[1] != h.shape[2] or h.shape[1] < 1:
        raise InputError("gaf", f"must have shape [nk={k.size}, m, m], got {list(h.shape)}")
    if h.size > MAX_ENTRIES:
        raise InputError("gaf", f"too large: {h.size} entries (at most {MAX_ENTRIES})")
    if not np.all(np.isfinite(h)):
        raise InputError("gaf", "must be finite (no NaN or infinity)")
    return GafTable(mach=m, k_values=k, gaf=h)


def read_gaf_npz(data: bytes) -> GafTable:
    """Table from NPZ bytes (``k``, ``gaf_real`` + ``gaf_imag`` or ``gaf``, ``mach``); InputError naming the key."""
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as z:
            arrays = {name: z[name] for name in z.files}
    except (ValueError, OSError, EOFError, zipfile.BadZipFile) as exc:
        raise InputError("file", f"not a readable NPZ file ({type(exc).__name__})") from None
    for key in ("k", "mach"):
        if key not in arrays:
            raise InputError(key, f"missing from the NPZ file (has {sorted(arrays)})")
    if "gaf" in arrays:
        h = arrays["gaf"]
    elif "gaf_real" in arrays and "gaf_imag" in arrays:
        if arrays["gaf_real"].shape != arrays["gaf_imag"].shape:
            raise InputError("gaf_imag", f"shape {list(arrays['gaf_imag'].shape)} differs from gaf_real's "
                                         f"{list(arrays['gaf_real'].shape)}")
        h = arrays["gaf_real"] + 1j * arrays["gaf_imag"]
    else:
        raise InputError("gaf", "missing from the NPZ file: give gaf_real and gaf_imag (or a complex gaf)")
    if np.size(arrays["mach"]) != 1:
        raise InputError("mach", "must be one number")
    return check_table(np.ravel(arrays["mach"])[0], np.ravel(arrays["k"]), h)


def read_gaf_csv(text: str, mach: float) -> GafTable:
    """Table from CSV text (header ``k,row,col,real,imag``; every (k, row, col) once) at ``mach``."""
    rows = list(csv.reader(io.StringIO(text)))
    if not rows or tuple(c.strip().lower() for c in rows[0]) != CSV_COLUMNS:
        raise InputError("file", f"the CSV header must be {','.join(CSV_COLUMNS)}")
    try:
        body = np.array([[float(c) for c in r] for r in rows[1:] if r], dtype=float)
    except ValueError:
        raise InputError("file", "every CSV value must be a number") from None
    if body.ndim != 2 or body.shape[0] == 0 or body.shape[1] != 5:
        raise InputError("file", "need one line of 5 values per table entry")
    k = np.unique(body[:, 0])
    idx = body[:, 1:3]
    if np.any(idx < 0) or np.any(idx != np.round(idx)):
        raise InputError("row", "rows and columns must be integers from 0")
    m = int(idx.max()) + 1
    if body.shape[0] != k.size * m * m:
        raise InputError("file", f"expected {k.size * m * m} lines ({k.size} k x {m} x {m}), got {body.shape[0]}")
    h = np.full((k.size, m, m), np.nan + 0j)
    kk = np.searchsorted(k, body[:, 0])
    h[kk, idx[:, 0].astype(int), idx[:, 1].astype(int)] = body[:, 3] + 1j * body[:, 4]
    if np.isnan(h.real).any():
        raise InputError("file", "some (k, row, col) entries are missing or repeated")
    return check_table(mach, k, h)


def gaf_npz(table: GafTable) -> bytes:
    """NPZ bytes of a table (the format ``read_gaf_npz`` reads)."""
    buf = io.BytesIO()
    np.savez(buf, k=table.k_values, gaf_real=table.gaf.real, gaf_imag=table.gaf.imag, mach=np.float64(table.mach))
    return buf.getvalue()


@dataclass
class TableSolver:
    """A GAF table behind the FrequencySolver protocol: returns the table's rows at the asked reduced frequencies
    (every one must be in the table: nothing is interpolated) for shapes with the table's column count."""

    table: GafTable
    name: str = "external"
    source: str = "an imported GAF table"
    warnings: list[str] = field(default_factory=list)

    def info(self, mach: float) -> SolverInfo:
        """Description and warnings (the table's Mach number must be the one asked)."""
        return SolverInfo(name=self.name, description=f"{self.source} at M {self.table.mach:g} "
                          f"({self.table.k_values.size} reduced frequencies to k {self.table.k_values[-1]:g})",
                          warnings=list(self.warnings))

    def gaf(self, mesh: StandardMesh, shapes: np.ndarray, mach: float, k_values: np.ndarray,
            progress: ProgressFn | None = None) -> np.ndarray:
        """H [nk, m, m] (m^3) of the table at ``k_values``; InputError if a k, m or the Mach is not the table's."""
        if abs(float(mach) - self.table.mach) > 1e-9:
            raise InputError("mach", f"the table is at M {self.table.mach:g}, not {float(mach):g}")
        if np.shape(shapes)[1] != self.table.n_shapes:
            raise InputError("gaf", f"the table has {self.table.n_shapes} shapes, the basis {np.shape(shapes)[1]}")
        k = np.asarray(k_values, dtype=float)
        pos = np.searchsorted(self.table.k_values, k)
        pos = np.minimum(pos, self.table.k_values.size - 1)
        if not np.allclose(self.table.k_values[pos], k, rtol=0.0, atol=1e-12):
            raise InputError("k_values", "every reduced frequency asked must be one of the table's")
        if progress is not None:
            progress(1.0, "table read")
        return self.table.gaf[pos]


def on_mass_normalized_modes(table: GafTable, generalized_masses: Any) -> GafTable:
    """The table of modes phi with generalized masses m (kg m^2 per unit coordinate) on the mass-normalized modes
    phi / sqrt(m): H_ij / sqrt(m_i m_j) (m^3 per unit mass-normalized coordinate); None: already normalized."""
    if generalized_masses is None:
        return table
    m = np.asarray(generalized_masses, dtype=float)
    if m.shape != (table.n_shapes,) or not np.all(np.isfinite(m)) or np.any(m <= 0):
        raise InputError("generalized_masses", f"expected {table.n_shapes} finite masses > 0, got {m.tolist()[:6]}")
    s = 1.0 / np.sqrt(m)
    return replace(table, gaf=table.gaf * s[None, :, None] * s[None, None, :])
