"""Nastran's generalized aerodynamic matrices QHH as a GAF table (``romams_core.gaf_table``).

What a flutter run (SOL 145) writes and how it becomes our table:

- **Blocks.** QHH holds one complex h x h matrix per Mach / reduced-frequency (m-k) pair of the MKAERO1 cards.
  An OUTPUT4 of QHH inside the flutter loop writes one h x h matrix of that name per pair, in sequence (a
  public OP4 of a SOL 145 run, pyNastran's ``bah_plane_qhh.op4``, holds 30 such 10 x 10 matrices for its
  2 Machs x 15 k); a list form writes one matrix of h rows and h x n_mk columns, the blocks side by side.
  Both are read: the blocks in file order (several matrices) or left to right (one wide matrix).
- **Order of the pairs.** For one MKAERO1 card: every k of the card's first Mach, then every k of its next Mach
  (checked on that public file); several cards follow card by card. The reader takes the k list of one card
  (``k_values``, in the card's order) and the number of Machs before the wanted one (``mach_index``): block
  ``mach_index * nk + j`` is k_j. This is an assumption on the layout, checked on one file only; a table with
  more than 8 k per Mach (several MKAERO1 cards) is read correctly when the run has one Mach.
- **Reduced frequency.** Nastran's k is on REFC / 2 (the AERO card's reference chord); ours on c_ref / 2 of
  the wing's standard mesh (its root chord). With ``refc`` and ``c_ref`` (m, both) the k values are rescaled,
  k_ours = k_nastran * c_ref / refc; the matrices themselves do not depend on the reference length.
- **Forces.** QHH excludes the dynamic pressure (generalized forces F = q QHH u), as our H does; with the
  modes the wing's basis shapes (displacement in m, in the basis' order) QHH is H in m^3 per unit generalized
  displacement. A model in other length units scales QHH by L^3: convert it first. Leading rows and columns
  that are not basis shapes (rigid-body modes, say) are dropped with ``skip_modes``; the rest must be the
  basis shapes.

Files: an OUTPUT4 (ASCII or binary, read by pyNastran's OP4 reader) or a punch file with DMIG cards of the
matrix (read by pyNastran's BDF reader; rows = the distinct (grid, component) row labels ascending, columns
likewise, h rows and h x n_mk columns in the block layout above). The OP4 holds no Mach or k: the caller gives
them. Errors are InputErrors naming ``file``, ``matrix``, ``k_values``, ``mach``, ``mach_index``,
``skip_modes`` or ``refc``; their texts never name a path of this machine.
"""

from __future__ import annotations

import io
import os
import re
import tempfile
import warnings
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from romams_core.errors import InputError
from romams_core.gaf_table import MAX_ENTRIES, GafTable, check_table
from romams_core.nastran.deck import _numpy2_aliases, import_pynastran

#: the matrix name read unless another is given
DEFAULT_MATRIX = "QHH"
#: a Nastran matrix name: 1-8 letters and digits, starting with a letter
MATRIX_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,7}")
#: the first line of an ASCII OUTPUT4 matrix: ncols, nrows, form, type, then the name
_OP4_ASCII_HEADER = re.compile(rb"\A\s*\d+\s+-?\d+\s+\d+\s+[1-4]\s*[A-Za-z]")
#: the first record length of a binary OUTPUT4 (24 bytes; 48 for 64-bit words), either byte order
_OP4_BINARY_START = (b"\x18\x00\x00\x00", b"\x00\x00\x00\x18", b"\x30\x00\x00\x00", b"\x00\x00\x00\x30")
#: a punch card of a direct matrix input (small or large field)
_DMIG_CARD = re.compile(rb"^DMIG\*?[\s,]", re.MULTILINE)
#: a NaN or infinite value in an ASCII OUTPUT4 (pyNastran counts values by their exponent letter and misreads it)
_NOT_FINITE = re.compile(rb"(?<![0-9A-Za-z.])[+-]?(?:nan|inf)", re.IGNORECASE)


@dataclass(frozen=True)
class QhhLayout:
    """What a QHH file does not say: the MKAERO1 k list (Nastran's k, on REFC/2, in the card's order), which
    Mach block (``mach_index``, from 0), the matrix name, leading modes to drop, and REFC (m; None: c_ref)."""

    k_values: tuple[float, ...]
    matrix: str = DEFAULT_MATRIX
    mach_index: int = 0
    skip_modes: int = 0
    refc: float | None = None

    def __post_init__(self) -> None:
        """Validate every field (InputError naming it)."""
        object.__setattr__(self, "k_values", _check_k_list(self.k_values))
        if not isinstance(self.matrix, str) or MATRIX_NAME.fullmatch(self.matrix) is None:
            raise InputError("matrix", "must be a Nastran matrix name (1-8 letters, digits or _, a letter first), "
                                       f"got {self.matrix!r}")
        object.__setattr__(self, "matrix", self.matrix.upper())
        for name in ("mach_index", "skip_modes"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 0:
                raise InputError(name, f"must be an integer >= 0, got {value!r}")
        if self.refc is not None and not (isinstance(self.refc, int | float) and np.isfinite(self.refc)
                                          and self.refc > 0):
            raise InputError("refc", f"must be a positive length (m), got {self.refc!r}")


def _check_k_list(k_values: Any) -> tuple[float, ...]:
    """Nastran's k list as floats: non-empty, finite, >= 0, no repeats (any order); InputError naming k_values."""
    try:
        k = np.asarray(k_values, dtype=float)
    except (TypeError, ValueError):
        raise InputError("k_values", "must be a list of numbers (the MKAERO1 reduced frequencies)") from None
    if k.ndim != 1 or k.size == 0:
        raise InputError("k_values", "must be a non-empty list of reduced frequencies (the MKAERO1 k list)")
    if not np.all(np.isfinite(k)) or np.any(k < 0):
        raise InputError("k_values", "must be finite and >= 0")
    if np.unique(k).size != k.size:
        raise InputError("k_values", "a reduced frequency is repeated")
    return tuple(float(x) for x in k)


def is_op4(data: bytes) -> bool:
    """True when ``data`` starts like an OUTPUT4 file (ASCII header line or binary first record)."""
    return data[:4] in _OP4_BINARY_START or _OP4_ASCII_HEADER.match(data[:200]) is not None


def is_punch(data: bytes) -> bool:
    """True when ``data`` holds a DMIG card (a punch file of direct matrix input)."""
    return _DMIG_CARD.search(data[:1 << 20]) is not None


def blocks_of(matrices: list[np.ndarray], matrix: str) -> np.ndarray:
    """[n_blocks, h, h] complex: the h x h blocks of one wide matrix (h x h*n, left to right) or of several
    h x h matrices (file order); InputError naming ``matrix`` when the sizes do not fit."""
    shapes = {m.shape for m in matrices}
    if len(shapes) != 1:
        raise InputError("matrix", f"the {len(matrices)} matrices {matrix} have different sizes "
                                   f"{sorted(shapes)[:4]}")
    h, ncols = matrices[0].shape
    if h < 1 or ncols % h:
        raise InputError("matrix", f"{matrix} is {h} x {ncols}: need h rows and h x n columns (n m-k pairs)")
    wide = np.hstack([np.asarray(m, dtype=complex) for m in matrices])
    return wide.reshape(h, wide.shape[1] // h, h).transpose(1, 0, 2)


def qhh_table(blocks: np.ndarray, mach: Any, layout: QhhLayout, c_ref: float | None = None,
              source: str = "") -> GafTable:
    """The GAF table of one Mach block of QHH blocks [n_blocks, h, h]: the layout's Mach block, leading modes
    dropped, sorted by k, k rescaled by c_ref / refc (c_ref in m; no rescaling without refc)."""
    nk = len(layout.k_values)
    n_blocks, h, _ = blocks.shape
    if n_blocks % nk:
        raise InputError("k_values", f"{layout.matrix} holds {n_blocks} blocks of {h} x {h} (m-k pairs), not a "
                                     f"multiple of the {nk} reduced frequencies given")
    n_mach = n_blocks // nk
    if layout.mach_index >= n_mach:
        raise InputError("mach_index", f"{layout.matrix} holds {n_mach} Mach block(s) of {nk} k; "
                                       f"mach_index {layout.mach_index} is beyond them")
    if layout.skip_modes >= h:
        raise InputError("skip_modes", f"{layout.matrix} has {h} modes; cannot skip {layout.skip_modes}")
    s = layout.skip_modes
    sel = blocks[layout.mach_index * nk:(layout.mach_index + 1) * nk, s:, s:]
    order = np.argsort(layout.k_values, kind="stable")
    k = np.asarray(layout.k_values)[order] * _k_scale(layout.refc, c_ref)
    return replace(check_table(mach, k, sel[order]), source=source)


def _k_scale(refc: float | None, c_ref: float | None) -> float:
    """c_ref / refc: Nastran's k (on REFC/2) times this is ours (on c_ref/2); 1 without refc."""
    if refc is None:
        return 1.0
    if c_ref is None or not c_ref > 0:
        raise InputError("refc", "rescaling k needs the wing's reference chord c_ref")
    return float(c_ref) / float(refc)


def read_qhh_op4(data: bytes, mach: Any, layout: QhhLayout, c_ref: float | None = None) -> GafTable:
    """GAF table from the bytes of an OUTPUT4 file (ASCII or binary) holding ``layout.matrix``."""
    matrices = _op4_matrices(data, layout.matrix)
    note = f"Nastran {layout.matrix} (OP4, Mach block {layout.mach_index}{_scale_note(layout, c_ref)})"
    return qhh_table(blocks_of(matrices, layout.matrix), mach, layout, c_ref, note)


def read_qhh_punch(data: bytes, mach: Any, layout: QhhLayout, c_ref: float | None = None) -> GafTable:
    """GAF table from the bytes of a punch file holding DMIG cards of ``layout.matrix``."""
    matrix = _punch_matrix(data, layout.matrix)
    note = f"Nastran {layout.matrix} (DMIG punch, Mach block {layout.mach_index}{_scale_note(layout, c_ref)})"
    return qhh_table(blocks_of([matrix], layout.matrix), mach, layout, c_ref, note)


def _scale_note(layout: QhhLayout, c_ref: float | None) -> str:
    """', k x <c_ref/refc>' when k is rescaled, else ''."""
    return "" if layout.refc is None else f", k x {_k_scale(layout.refc, c_ref):.6g} (c_ref / REFC)"


def _read_op4_function() -> Any:
    """pyNastran's ``read_op4`` (ImportError saying how to install pyNastran)."""
    import_pynastran()
    with _numpy2_aliases():
        from pyNastran.op4.op4 import read_op4
    return read_op4


def _quiet_log() -> Any:
    """A pyNastran logger that shows errors only."""
    from cpylog import SimpleLogger

    return SimpleLogger(level="error")


def _op4_matrices(data: bytes, name: str) -> list[np.ndarray]:
    """The matrices called ``name`` of an OP4 file, in file order; InputError naming ``file`` or ``matrix``."""
    if b"\0" not in data and _NOT_FINITE.search(data):
        raise InputError("gaf", "the OP4 file holds a NaN or infinite value: must be finite")
    read_op4 = _read_op4_function()
    with tempfile.TemporaryDirectory(prefix="romams-op4-") as tmp:  # pyNastran reads OP4 from a path only
        path = os.path.join(tmp, "qhh.op4")
        with open(path, "wb") as f:
            f.write(data)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                found = read_op4(path, precision="double", log=_quiet_log())
        except MemoryError:
            raise InputError("file", "the OP4 file declares a matrix too large to read") from None
        except Exception as exc:  # pyNastran raises many types on a malformed file; its texts hold the path
            raise InputError("file", f"not a readable OUTPUT4 file ({type(exc).__name__})") from None
    names = {str(k).strip().upper(): v for k, v in found.items()}
    if name not in names:
        held = sorted(names)[:10]
        raise InputError("matrix", f"no matrix {name!r} in the OP4 file (it holds {held or 'none'})")
    data_ = names[name].data
    parts = data_ if isinstance(data_, list) else [data_]
    return [_dense(p, name) for p in parts]


def _dense(part: Any, name: str) -> np.ndarray:
    """A dense 2-D array of one OP4 matrix (dense or sparse), refused above the table's size limit."""
    shape = tuple(getattr(part, "shape", ()))
    if len(shape) != 2:
        raise InputError("matrix", f"{name} is not a 2-D matrix")
    if shape[0] * shape[1] > 4 * MAX_ENTRIES:
        raise InputError("matrix", f"{name} is {shape[0]} x {shape[1]}: too large")
    return np.asarray(part.toarray() if hasattr(part, "toarray") else part)


def _punch_text(data: bytes) -> str:
    """The punch file's cards without comment lines (no pyNastran header directive); no INCLUDE allowed."""
    text = data.decode("latin-1")
    lines = [ln for ln in text.splitlines() if not ln.lstrip().startswith("$")]
    if any(ln.lstrip().upper().startswith("INCLUDE") for ln in lines):
        raise InputError("file", "a punch file must not INCLUDE other files")
    return "\n".join(lines) + "\n"


def _punch_matrix(data: bytes, name: str) -> np.ndarray:
    """The dense matrix of the DMIG cards called ``name``: rows and columns = the distinct (grid, component)
    labels ascending; InputError naming ``file`` or ``matrix``."""
    BDF, _ = import_pynastran()
    model = BDF(debug=None, log=_quiet_log())
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model.read_bdf(io.StringIO(_punch_text(data)), validate=False, xref=False, punch=True,
                           read_includes=False)
    except Exception as exc:  # pyNastran raises many types on malformed cards
        raise InputError("file", f"not a readable punch file ({type(exc).__name__})") from None
    dmig = {str(k).strip().upper(): v for k, v in model.dmig.items()}
    if name not in dmig:
        held = sorted(dmig)[:10]
        raise InputError("matrix", f"no DMIG matrix {name!r} in the punch file (it holds {held or 'none'})")
    return _dmig_dense(dmig[name], name)


def _dmig_dense(dmig: Any, name: str) -> np.ndarray:
    """Dense complex matrix of one pyNastran DMIG (each entry once; forms square or rectangular)."""
    if int(dmig.matrix_form) not in (1, 2, 9):
        raise InputError("matrix", f"{name} has DMIG form {dmig.matrix_form}; QHH is square or rectangular (1, 2, 9)")
    gci = np.asarray(dmig.GCi, dtype=np.int64).reshape(-1, 2)
    gcj = np.asarray(dmig.GCj, dtype=np.int64).reshape(-1, 2)
    values = np.asarray(dmig.Real, dtype=float) + (1j * np.asarray(dmig.Complex, dtype=float) if dmig.is_complex
                                                    else 0.0)
    rows, ri = np.unique(gci, axis=0, return_inverse=True)
    cols, cj = np.unique(gcj, axis=0, return_inverse=True)
    if rows.shape[0] * cols.shape[0] > 4 * MAX_ENTRIES:
        raise InputError("matrix", f"{name} is {rows.shape[0]} x {cols.shape[0]}: too large")
    flat = ri.ravel() * cols.shape[0] + cj.ravel()
    if np.unique(flat).size != flat.size:
        raise InputError("file", f"an entry of {name} is given twice")
    out = np.zeros((rows.shape[0], cols.shape[0]), dtype=complex)
    out[ri.ravel(), cj.ravel()] = values
    return out
