"""External mode shapes (JSON, NPZ, Nastran BDF + OP2) and their mapping onto the standard mesh.

An external structure arrives as FE node coordinates [P, 3] (m), out-of-plane displacements per
mode [P, k] (m per unit modal coordinate), natural frequencies [k] (Hz) and, optionally, the
generalized masses [k] (kg m^2 per unit modal coordinate squared, i.e. phi^T M phi) and the
structural mass (kg). Shapes with generalized masses are mass-normalized by dividing by
sqrt(generalized mass); without them they are taken as already mass-normalized (Nastran's
default EIGRL normalization, NORM=MASS).

The node coordinates must be in the wing's frame (x aft, y span from the root, z up, metres).
Nodes are projected on the wing plane (z dropped) and interpolated onto the standard mesh with
:func:`romams_core.structure.mapping.map_to_mesh`, after checking that they cover the planform.
"""

from __future__ import annotations

import json
import math
import os
import zipfile
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial import Delaunay, QhullError, cKDTree

from romams_core.errors import InputError
from romams_core.mesh import StandardMesh
from romams_core.structure.mapping import map_to_mesh
from romams_core.structure.modal import ModalResult

PathLike = str | os.PathLike[str]

# coverage tolerances, in planform fractions (chord fraction xi, span fraction eta)
_MAX_GAP = 0.2  # every standard-mesh node needs an FE node within this (xi, eta) distance
_MIN_INSIDE = 0.9  # fraction of (slightly shrunk) standard-mesh nodes inside the FE nodes' hull
_MIN_ON_WING = 0.9  # fraction of FE nodes on the planform grown by _MARGIN
_MARGIN = 0.05
_MAX_Z_SPREAD = 0.1  # out-of-plane node spread, fraction of max(root chord, semispan)


@dataclass
class ExternalModes:
    """Mode shapes of a structure from an outside FE model (m, Hz, kg)."""

    nodes: np.ndarray  # [P, 3] node coordinates, m
    shapes: np.ndarray  # [P, k] out-of-plane displacement per mode
    frequencies_hz: np.ndarray  # [k] natural frequencies, Hz
    generalized_masses: np.ndarray | None = None  # [k] phi^T M phi, or None if mass-normalized
    mass_kg: float | None = None  # structural mass, kg
    source: str = ""  # where the modes came from (file name, "json", ...)
    rotations: np.ndarray | None = None  # [2, P, k] rotations about x and y (rad, basic frame; Nastran R1, R2)
    grid_ids: np.ndarray | None = None  # [P] FE node ids (Nastran GRID ids), for messages
    spline: str = "auto"  # how the shapes go onto the standard mesh: one of SPLINES

    def __post_init__(self) -> None:
        nodes = _float_array("nodes", self.nodes)
        if nodes.ndim != 2 or nodes.shape[1] not in (2, 3):
            raise InputError("nodes", f"expected shape [P, 3] (or [P, 2]), got {nodes.shape}")
        if nodes.shape[1] == 2:
            nodes = np.column_stack([nodes, np.zeros(nodes.shape[0])])
        n_pts = nodes.shape[0]
        if n_pts < 3:
            raise InputError("nodes", f"need at least 3 nodes, got {n_pts}")
        freqs = _float_array("frequencies_hz", self.frequencies_hz)
        if freqs.ndim != 1 or freqs.size < 1:
            raise InputError("frequencies_hz", f"expected a non-empty list [k], got shape {freqs.shape}")
        if np.any(freqs <= 0.0):
            raise InputError("frequencies_hz", f"must all be > 0 Hz, got {freqs[freqs <= 0.0].tolist()[:5]}")
        k = freqs.size
        shapes = _float_array("shapes", self.shapes)
        if shapes.ndim == 1 and k == 1:
            shapes = shapes[:, None]
        if shapes.ndim != 2 or shapes.shape != (n_pts, k):
            raise InputError(
                "shapes", f"expected [{n_pts} nodes, {k} modes] to match nodes and frequencies_hz, got {shapes.shape}"
            )
        zero = np.flatnonzero(~np.any(shapes != 0.0, axis=0))
        if zero.size:
            raise InputError("shapes", f"modes {zero.tolist()} are identically zero")
        gm = None
        if self.generalized_masses is not None:
            gm = _float_array("generalized_masses", self.generalized_masses).ravel()
            if gm.size != k:
                raise InputError("generalized_masses", f"expected {k} values (one per mode), got {gm.size}")
            if np.any(gm <= 0.0):
                raise InputError("generalized_masses", "must all be > 0")
        mass = self.mass_kg
        if mass is not None:
            if not (isinstance(mass, int | float | np.floating | np.integer) and math.isfinite(mass) and mass > 0):
                raise InputError("mass_kg", f"must be a finite number > 0 or null, got {mass!r}")
            mass = float(mass)
        if self.rotations is not None:
            rot = _float_array("rotations", self.rotations)
            if rot.shape != (2, n_pts, k):
                raise InputError("rotations", f"expected [2, {n_pts} nodes, {k} modes], got {rot.shape}")
            self.rotations = rot
        if self.spline not in SPLINES:
            raise InputError("spline", f"must be one of {SPLINES}, got {self.spline!r}")
        if self.grid_ids is not None:
            ids = np.asarray(self.grid_ids).astype(int).ravel()
            if ids.size != n_pts:
                raise InputError("grid_ids", f"expected {n_pts} ids (one per node), got {ids.size}")
            self.grid_ids = ids
        self.nodes, self.shapes, self.frequencies_hz = nodes, shapes, freqs
        self.generalized_masses, self.mass_kg = gm, mass

    @property
    def n_modes(self) -> int:
        """Number of modes k."""
        return int(self.frequencies_hz.size)

    def mass_normalized_shapes(self) -> np.ndarray:
        """Shapes [P, k] scaled to unit generalized mass (m per unit modal coordinate)."""
        if self.generalized_masses is None:
            return self.shapes.copy()
        return self.shapes / np.sqrt(self.generalized_masses)

    def mass_normalized_rotations(self) -> np.ndarray | None:
        """Rotations [2, P, k] scaled like :meth:`mass_normalized_shapes` (rad per unit modal coordinate)."""
        if self.rotations is None:
            return None
        if self.generalized_masses is None:
            return self.rotations.copy()
        return self.rotations / np.sqrt(self.generalized_masses)


def _float_array(name: str, value: Any) -> np.ndarray:
    """Finite float array from ``value``; ValueError naming ``name`` otherwise."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InputError(name, f"not a numeric array ({exc})") from None
    if not np.all(np.isfinite(arr)):
        raise InputError(name, "contains NaN or infinite values")
    return arr


def _shapes_from_modes_first(name: str, value: Any, n_nodes: int, n_modes: int) -> np.ndarray:
    """Shapes given one row per mode ([k][P], as in the API) or [P, k] -> [P, k]."""
    arr = _float_array(name, value)
    if arr.ndim == 2 and arr.shape == (n_modes, n_nodes):
        return arr.T
    if arr.ndim == 2 and arr.shape == (n_nodes, n_modes):
        return arr
    if arr.ndim == 1 and n_modes == 1 and arr.size == n_nodes:
        return arr[:, None]
    raise InputError(
        name, f"expected {n_modes} modes x {n_nodes} nodes (one list per mode) to match nodes and "
        f"frequencies_hz, got shape {arr.shape}"
    )


def modes_from_dict(d: Mapping[str, Any], source: str = "json") -> ExternalModes:
    """ExternalModes from a mapping with keys nodes, shapes, frequencies_hz[, generalized_masses, mass_kg]."""
    if not isinstance(d, Mapping):
        raise InputError("modes", f"expected a JSON object, got {type(d).__name__}")
    for key in ("nodes", "shapes", "frequencies_hz"):
        if key not in d:
            raise InputError(key, "missing (required keys: nodes, shapes, frequencies_hz)")
    nodes = _float_array("nodes", d["nodes"])
    freqs = _float_array("frequencies_hz", d["frequencies_hz"])
    if nodes.ndim != 2 or freqs.ndim != 1:
        raise InputError(
            "nodes", f"expected [P, 3] with frequencies_hz [k]; got nodes {nodes.shape}, frequencies_hz {freqs.shape}"
        )
    shapes = _shapes_from_modes_first("shapes", d["shapes"], nodes.shape[0], freqs.size)
    return ExternalModes(
        nodes=nodes,
        shapes=shapes,
        frequencies_hz=freqs,
        generalized_masses=d.get("generalized_masses"),
        mass_kg=d.get("mass_kg"),
        source=source,
    )


def load_modes_json(src: PathLike | Mapping[str, Any]) -> ExternalModes:
    """Read external modes from a JSON file (or an already parsed dict); shapes one list per mode."""
    if isinstance(src, Mapping):
        return modes_from_dict(src, "json")
    if not isinstance(src, str | os.PathLike):
        raise InputError("modes", f"expected a file path or a mapping, got {type(src).__name__}")
    path = Path(src)
    try:
        data = json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise InputError("json", f"{path.name} is not valid JSON ({exc})") from None
    return modes_from_dict(data, path.name)


#: the NPZ members :func:`load_modes_npz` reads (any other member is ignored, never decompressed)
NPZ_KEYS = ("nodes", "shapes", "frequencies_hz", "generalized_masses", "mass_kg")
#: default bound of :func:`load_modes_npz` on the arrays' total size once decompressed (bytes)
NPZ_MAX_BYTES = 100_000_000
_NPZ_MAX_MEMBERS = 64


def _npz_member_sizes(path: Path, max_bytes: int) -> None:
    """Check an NPZ before anything is decompressed: few members, and the declared size of each member read
    (zip directory) and of its array (.npy header: shape x itemsize, no object dtype) within ``max_bytes`` in all.

    Only the headers are inflated (a few hundred bytes each), so a small archive that would inflate to gigabytes
    is refused without the memory; a member inflating past its declared size fails the zip's own check."""
    try:
        with zipfile.ZipFile(path) as zf:
            infos = zf.infolist()
            if len(infos) > _NPZ_MAX_MEMBERS:
                raise InputError("npz", f"{path.name} has {len(infos)} members (at most {_NPZ_MAX_MEMBERS})")
            total = 0
            for info in infos:
                key = info.filename[:-4] if info.filename.endswith(".npy") else info.filename
                if key not in NPZ_KEYS:
                    continue
                total += info.file_size
                if total > max_bytes:
                    raise InputError(key, f"declares {info.file_size} bytes uncompressed; the arrays of an NPZ "
                                          f"may hold at most {max_bytes} bytes in all")
                with zf.open(info) as f:
                    version = np.lib.format.read_magic(f)
                    if version == (1, 0):
                        shape, _, dtype = np.lib.format.read_array_header_1_0(f)
                    elif version == (2, 0):
                        shape, _, dtype = np.lib.format.read_array_header_2_0(f)
                    else:
                        raise InputError(key, f"unsupported .npy format version {version}")
                if dtype.hasobject:
                    raise InputError(key, "cannot be read without pickle (object arrays are refused)")
                size = math.prod(int(n) for n in shape) * int(dtype.itemsize)
                if size > max_bytes or size > info.file_size:
                    raise InputError(key, f"array {tuple(shape)} of {dtype} ({size} bytes) exceeds the limit of "
                                          f"{max_bytes} bytes or its member's declared size")
    except (zipfile.BadZipFile, zipfile.LargeZipFile, OSError, EOFError, ValueError) as exc:
        if isinstance(exc, InputError):
            raise
        raise InputError("npz", f"{path.name} is not a readable NPZ archive ({exc})") from None


def load_modes_npz(path: PathLike, max_bytes: int | None = NPZ_MAX_BYTES) -> ExternalModes:
    """Read external modes from an NPZ (nodes [P, 3], shapes [P, k], frequencies_hz [k], optional extras).

    ``max_bytes`` bounds the arrays' total size once decompressed; it is checked from the zip directory and the
    .npy headers before any array is inflated (None: no bound). Pickle is never allowed."""
    path = Path(path)
    if not path.is_file() or not zipfile.is_zipfile(path):
        raise InputError("npz", f"{path.name} is not a readable NPZ archive")
    if max_bytes is not None:
        _npz_member_sizes(path, int(max_bytes))
    try:
        with np.load(path, allow_pickle=False) as z:
            data: dict[str, Any] = {}
            for key in z.files:
                if key not in NPZ_KEYS:
                    continue
                try:
                    data[key] = z[key]
                except ValueError as exc:  # object arrays need pickle: refused
                    raise InputError(key, f"cannot be read without pickle ({exc})") from None
    except (OSError, EOFError, zipfile.BadZipFile) as exc:
        raise InputError("npz", f"{path.name} is not a readable NPZ archive ({exc})") from None
    for key in ("generalized_masses", "mass_kg"):
        if key in data and data[key].size == 0:
            data.pop(key)
    if "mass_kg" in data:
        data["mass_kg"] = float(np.asarray(data["mass_kg"]).ravel()[0])
    for key in ("nodes", "shapes", "frequencies_hz"):
        if key not in data:
            raise InputError(key, f"missing from {path.name} (required keys: nodes, shapes, frequencies_hz)")
    nodes = _float_array("nodes", data["nodes"])
    freqs = _float_array("frequencies_hz", data["frequencies_hz"]).ravel()
    shapes = _float_array("shapes", data["shapes"])
    if nodes.ndim == 2 and shapes.ndim == 2 and shapes.shape == (freqs.size, nodes.shape[0]) != shapes.T.shape:
        shapes = shapes.T  # [k, P] given: unambiguous since k != P
    return ExternalModes(
        nodes=nodes,
        shapes=shapes,
        frequencies_hz=freqs,
        generalized_masses=data.get("generalized_masses"),
        mass_kg=data.get("mass_kg"),
        source=path.name,
    )


def _import_pynastran() -> tuple[type, type]:
    """pyNastran's BDF and OP2 classes (see :mod:`romams_core.nastran.deck`)."""
    from romams_core.nastran.deck import import_pynastran

    return import_pynastran()


def load_modes_nastran(bdf_path: PathLike, op2_path: PathLike, subcase: int | None = None,
                       n_modes: int | None = None, **kwargs: Any) -> ExternalModes:
    """Modes of a Nastran BDF + OP2 pair: :func:`romams_core.nastran.op2.load_modes_nastran`."""
    from romams_core.nastran.op2 import load_modes_nastran as load

    return load(bdf_path, op2_path, subcase, n_modes, **kwargs)


def _check_on_wing(pts: np.ndarray, mesh: StandardMesh) -> np.ndarray:
    """(xi, eta) [P, 2] of FE points [P, 2] (m); InputError unless most of them lie on the planform."""
    xi, eta = mesh.planform.to_xi_eta(pts[:, 0], pts[:, 1])
    fe = np.column_stack([xi, eta])
    on_wing = np.all((fe >= -_MARGIN) & (fe <= 1.0 + _MARGIN), axis=1)
    if on_wing.mean() < _MIN_ON_WING:
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        raise InputError(
            "nodes", f"only {on_wing.mean():.0%} of the FE nodes lie on the planform (nodes span "
            f"x {lo[0]:.4g}..{hi[0]:.4g} m, y {lo[1]:.4g}..{hi[1]:.4g} m; wrong units or axes? "
            "x aft, y span from the root, metres; a Nastran deck's wing: import it with its CAERO1 planform)"
        )
    return fe


def check_coverage(points_xy: np.ndarray, mesh: StandardMesh) -> None:
    """Raise ValueError unless FE points [P, 2] (m) lie on and cover the planform of ``mesh``."""
    pts = np.asarray(points_xy, dtype=float)
    fe = _check_on_wing(pts, mesh)
    if np.unique(np.round(pts / max(np.ptp(pts), 1e-300), 12), axis=0).shape[0] < pts.shape[0]:
        raise InputError("nodes", "two or more nodes share the same in-plane position (an RBE2 master on a "
                                  "structural node, or upper and lower skins? leave GRIDs out with the GRID "
                                  "selection: ids, or 'planform')")
    m_xi, m_eta = mesh.planform.to_xi_eta(mesh.x, mesh.y)
    target = np.column_stack([m_xi, m_eta])
    gap, _ = cKDTree(fe).query(target)
    try:
        hull = Delaunay(fe)
    except QhullError:
        raise InputError("nodes", "the FE nodes are collinear and cannot cover the planform (a stick model "
                                  "needs rotations R1/R2 for the beam spline)") from None
    shrunk = 0.5 + (target - 0.5) * 0.96  # tolerate round-off and edge nodes slightly inside the edges
    inside = float(np.mean(hull.find_simplex(shrunk) >= 0))
    if gap.max() > _MAX_GAP or inside < _MIN_INSIDE:
        raise InputError(
            "nodes", f"the FE nodes do not cover the planform (largest gap {gap.max():.2f} in chord/span fractions, "
            f"{inside:.0%} of the wing inside the nodes' hull; need <= {_MAX_GAP} and >= {_MIN_INSIDE:.0%})"
        )


def check_beam_coverage(points_xy: np.ndarray, mesh: StandardMesh) -> None:
    """InputError unless a stick model's nodes [P, 2] (m) lie on the planform and run from root to tip."""
    fe = _check_on_wing(np.asarray(points_xy, dtype=float), mesh)
    if fe[:, 1].min() > _MAX_GAP or fe[:, 1].max() < 1.0 - _MAX_GAP:
        raise InputError("nodes", f"the beam nodes span {fe[:, 1].min():.2f}..{fe[:, 1].max():.2f} of the semispan; "
                                  f"they must run from the root to the tip (gaps <= {_MAX_GAP})")


#: the mappings from FE nodes to the standard mesh (``auto``: beam for a stick model with rotations, else
#: clough-tocher, the historical default)
SPLINES = ("auto", "clough-tocher", "linear", "surface", "beam")


def choose_spline(modes: ExternalModes, spline: str = "auto") -> str:
    """The spline used for ``modes``: ``spline`` checked, or the automatic choice."""
    from romams_core.structure.splines import is_stick

    if spline not in SPLINES:
        raise InputError("spline", f"must be one of {SPLINES}, got {spline!r}")
    stick = is_stick(modes.nodes[:, :2])
    if spline == "auto":
        return "beam" if stick and modes.rotations is not None else "clough-tocher"
    if spline == "beam" and modes.rotations is None:
        raise InputError("spline", "the beam spline needs the nodes' rotations (R1, R2: a Nastran OP2)")
    return spline


def wing_modal_result(modes: ExternalModes, wing: Any, mesh: StandardMesh) -> ModalResult:
    """:func:`external_modal_result` with the modes' own spline and the wing's origin (imported planforms)."""
    return external_modal_result(modes, mesh, spline=modes.spline, origin=getattr(wing, "origin", None))


def external_modal_result(modes: ExternalModes, mesh: StandardMesh, smooth: bool = True, *, spline: str = "auto",
                          origin: Any = None) -> ModalResult:
    """ModalResult (mass-normalized shapes on the standard mesh, sorted by frequency) of external modes.

    ``origin`` (m): where the wing's root leading edge lies in the frame of the nodes (a Nastran deck's CAERO1
    corner); the nodes are moved by -origin. ``spline``: one of :data:`SPLINES`."""
    from romams_core.structure.splines import beam_spline, surface_spline

    planform = mesh.planform
    nodes = modes.nodes - (np.zeros(3) if origin is None else np.asarray(origin, dtype=float).reshape(3))
    z = nodes[:, 2]
    if np.ptp(z) > _MAX_Z_SPREAD * max(planform.root_chord, planform.semispan):
        raise InputError(
            "nodes", f"z spans {np.ptp(z):.4g} m; the nodes must lie near the wing plane z = 0 (x aft, y span, z up)"
        )
    xy = nodes[:, :2]
    method = choose_spline(modes, spline)
    order = np.argsort(modes.frequencies_hz, kind="stable")
    fe_shapes = modes.mass_normalized_shapes()[:, order]
    target = np.column_stack([mesh.x, mesh.y])
    if method == "beam":
        check_beam_coverage(xy, mesh)
        rot = modes.mass_normalized_rotations()
        assert rot is not None
        shapes = beam_spline(xy, fe_shapes, rot[:, :, order], target)
    else:
        check_coverage(xy, mesh)
        if method == "surface":
            shapes = surface_spline(xy, fe_shapes, target)
        else:
            shapes = map_to_mesh(xy, fe_shapes, mesh, smooth=smooth and method == "clough-tocher")
    sign = _sign_convention(shapes)
    freqs = modes.frequencies_hz[order]
    return ModalResult(
        frequencies_hz=freqs,
        omega=2.0 * np.pi * freqs,
        shapes=shapes * sign,
        mass_kg=math.nan if modes.mass_kg is None else float(modes.mass_kg),
        n_fe_nodes=int(xy.shape[0]),
        fe_xy=xy.copy(),
        fe_shapes=fe_shapes * sign,
    )


def _sign_convention(shapes: np.ndarray) -> np.ndarray:
    """Signs [k] that make each column's largest-magnitude entry positive."""
    idx = np.argmax(np.abs(shapes), axis=0)
    s = np.sign(shapes[idx, np.arange(shapes.shape[1])])
    s[s == 0] = 1.0
    return s
