"""Reading a Nastran bulk-data deck through pyNastran: the import shim, confined INCLUDEs, path-free messages.

A deck may come as one file or as a folder holding the main file and its INCLUDE files (an upload's zip, or
several uploaded files). With ``confine=True`` every INCLUDE statement must name a relative file inside that
folder (no absolute path, no ``..``, no environment variable), so a deck cannot make the reader open a file of
the machine it runs on. Error texts name files by their base name only (:func:`scrub`).
"""

from __future__ import annotations

import contextlib
import os
import re
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from romams_core.errors import InputError

PathLike = str | os.PathLike[str]

_ABS_PATH = re.compile(r"(?<![\w.])(?:[A-Za-z]:)?(?:[\\/][^\s'\"\\/:,;()]+)+[\\/]?")
_INCLUDE = re.compile(r"^\s*include\b", re.IGNORECASE)


def scrub(text: str) -> str:
    """``text`` with every absolute file path cut to its base name (no server folder in an error message)."""
    return _ABS_PATH.sub(lambda m: re.split(r"[\\/]", m.group(0).rstrip("/\\"))[-1] or "<path>", str(text))


@contextlib.contextmanager
def _numpy2_aliases() -> Iterator[None]:
    """Temporarily provide ``np.in1d`` (removed in numpy 2.4), which pyNastran 1.4.1 binds at import."""
    added = not hasattr(np, "in1d")
    if added:

        def in1d(ar1: Any, ar2: Any, assume_unique: bool = False, invert: bool = False) -> np.ndarray:
            return np.isin(np.ravel(ar1), ar2, assume_unique=assume_unique, invert=invert)

        setattr(np, "in1d", in1d)  # noqa: B010 (name removed from numpy)
    try:
        yield
    finally:
        if added:
            delattr(np, "in1d")  # noqa: B043


def import_pynastran() -> tuple[type, type]:
    """pyNastran's BDF and OP2 classes, or ImportError saying how to install it."""
    try:
        with _numpy2_aliases():
            from pyNastran.bdf.bdf import BDF
            from pyNastran.op2.op2 import OP2
    except ImportError as exc:
        raise ImportError(
            "Nastran BDF/OP2 input needs pyNastran: pip install --no-deps 'pyNastran==1.4.1' cpylog "
            f"(or `make install`); import failed: {exc}"
        ) from exc
    return BDF, OP2


def _bdf_is_bulk_only(path: Path) -> bool:
    """True when a BDF has no BEGIN BULK line (a bulk-data-only 'punch' file)."""
    with path.open("r", errors="replace") as f:
        return not any(line.lstrip().upper().startswith("BEGIN") and "BULK" in line.upper() for line in f)


def _include_names(path: Path) -> list[str]:
    """File names of the INCLUDE statements of one deck file (quoted names may continue on later lines)."""
    names: list[str] = []
    lines = path.read_text(errors="replace").splitlines()
    i = 0
    while i < len(lines):
        line = lines[i]
        i += 1
        if not _INCLUDE.match(line):
            continue
        text = line.split(None, 1)[1] if len(line.split(None, 1)) > 1 else ""
        while text.count("'") == 1 and i < len(lines):  # an open quote continues on the next line
            text += lines[i].strip()
            i += 1
        names.append(text.strip().strip("'\"").strip())
    return names


def check_includes(folder: Path) -> None:
    """InputError unless every INCLUDE of every file in ``folder`` names a relative file inside it."""
    root = folder.resolve()
    for path in sorted(p for p in folder.rglob("*") if p.is_file()):
        for name in _include_names(path):
            bad = (not name or name.startswith(("/", "\\", "~")) or "$" in name or ":" in name
                   or ".." in re.split(r"[\\/]", name))
            target = (path.parent / name).resolve()
            if bad or root not in target.parents:
                raise InputError("bdf", f"{path.name}: INCLUDE {os.path.basename(name)!r} must name a file of the "
                                        "upload by a relative path (no folder outside it, no variable)")
            if not target.is_file():
                raise InputError("bdf", f"{path.name}: INCLUDE {os.path.basename(name)!r} is not among the uploaded "
                                        "files (upload a zip, or all files of the deck)")


def read_bdf(bdf_path: PathLike, *, confine: bool = False, xref_coords: bool = True) -> Any:
    """pyNastran BDF model of a deck (main file ``bdf_path``; INCLUDEs relative to its folder).

    ``confine``: the INCLUDEs must stay inside the main file's folder (uploads). Nodes and coordinate systems
    are cross-referenced (positions in the basic frame); InputError naming ``bdf`` on a deck pyNastran refuses.
    """
    path = Path(bdf_path)
    if not path.is_file():
        raise InputError("bdf", f"file {path.name!r} not found")
    if confine:
        check_includes(path.parent)
    BDF, _ = import_pynastran()
    model = BDF(debug=None)
    try:  # INCLUDE names resolve against the main file's folder (never the process's working folder)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model.read_bdf(str(path.resolve()), validate=False, xref=False, punch=_bdf_is_bulk_only(path))
        if xref_coords:
            model.cross_reference(
                xref_nodes=True, xref_elements=False, xref_properties=False, xref_masses=False,
                xref_materials=False, xref_loads=False, xref_constraints=False, xref_aero=False,
                xref_sets=False, xref_optimization=False,
            )
    except InputError:
        raise
    except Exception as exc:  # pyNastran raises many types on malformed decks
        raise InputError("bdf", f"cannot read {path.name} ({type(exc).__name__}: {scrub(str(exc))[:500]})") from None
    return model


def main_deck(folder: Path) -> Path:
    """The main file of an uploaded deck folder: the one file with BEGIN BULK (or a CEND), else the only one."""
    files = sorted(p for p in folder.rglob("*") if p.is_file() and p.suffix.lower() in (".bdf", ".dat", ".nas",
                                                                                        ".blk", ".bulk", ".inc"))
    if not files:
        raise InputError("bdf", "no deck file (.bdf, .dat, .nas, .blk, .bulk) in the upload")
    if len(files) == 1:
        return files[0]
    mains = [p for p in files if not _bdf_is_bulk_only(p)]
    if len(mains) == 1:
        return mains[0]
    included = {os.path.normpath(p.parent / n) for p in files for n in _include_names(p)}
    roots = [p for p in files if os.path.normpath(p) not in included]
    if len(roots) == 1:
        return roots[0]
    raise InputError("bdf", f"cannot tell the main deck among {[p.name for p in files][:10]}: give one file with "
                            "BEGIN BULK, or one file that INCLUDEs the others")


def param_value(model: Any, name: str, default: float) -> float:
    """A PARAM's first value (e.g. WTMASS), ``default`` when absent."""
    p = model.params.get(name)
    if p is None:
        return float(default)
    try:
        return float(p.values[0])
    except (TypeError, ValueError, IndexError):
        raise InputError(name.lower(), f"PARAM,{name} is not a number ({p.values!r})") from None


def coord_rotation(model: Any, cid: int, field: str) -> np.ndarray:
    """Rows = the unit axes of rectangular coordinate system ``cid`` in the basic frame; InputError otherwise."""
    if cid == 0:
        return np.eye(3)
    coord = model.coords.get(int(cid))
    if coord is None:
        raise InputError(field, f"coordinate system {cid} is not defined")
    if coord.Type != "R":
        raise InputError(field, f"coordinate system {cid} is {coord.type}; only rectangular is supported")
    if coord.i is None:
        coord.setup()
    return np.vstack([coord.i, coord.j, coord.k])
