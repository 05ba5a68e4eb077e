"""Real eigenvectors of a Nastran OP2 (SOL 103, or the structural modes inside a SOL 145 OP2) as ExternalModes.

What is read: GRID positions (BDF, CP frames resolved to basic), the real eigenvector table (T1..R3 per GRID,
CD frames rotated to basic), the eigenvalues (frequency = sqrt(lambda) / 2 pi) and, from a real eigenvalue
table (LAMA), the generalized masses. Complex eigenvalue tables (CLAMA of a flutter run) are ignored.

Choices (:class:`NastranOptions`): the subcase, the modes (ids or a count), skipping rigid-body modes below a
frequency, the GRIDs (ids, or those inside the deck's CAERO1 planform), and the deck's units. Nastran solves
with the mass matrix scaled by PARAM,WTMASS, so its eigenvectors and generalized masses are in the deck's
consistent units (mass unit = force unit s^2 / length unit); ``units`` names that system and the shapes are
converted to SI: displacement x length scale, generalized mass x mass scale x length scale^2. The structural
mass (kg) is WTMASS x the deck's mass sum x the mass scale.
"""

from __future__ import annotations

import dataclasses
import math
import re
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from romams_core.errors import InputError
from romams_core.modes_io import ExternalModes, PathLike
from romams_core.nastran.deck import coord_rotation, import_pynastran, read_bdf, scrub

_LBF_N = 4.4482216152605
#: consistent Nastran unit systems -> (metres per length unit, kg per mass unit = force unit s^2 / length unit)
UNIT_SYSTEMS: dict[str, tuple[float, float]] = {
    "si": (1.0, 1.0),  # m, kg, N, s
    "mm-t-s": (1.0e-3, 1.0e3),  # mm, tonne, N, s
    "mm-kg-ms": (1.0e-3, 1.0),  # mm, kg, kN, ms: frequencies would be per ms, so refused below
    "in-lbf-s": (0.0254, _LBF_N / 0.0254),  # in, lbf s^2/in, lbf, s
    "ft-lbf-s": (0.3048, _LBF_N / 0.3048),  # ft, slug, lbf, s
}
_TIME_IN_MS = {"mm-kg-ms"}


@dataclass(frozen=True)
class NastranOptions:
    """How to read modes from an OP2: subcase, modes, rigid-body skip, GRIDs, units, WTMASS override."""

    subcase: int | None = None
    modes: str | int | Sequence[int] | None = None  # "1,2,4" / [1, 2, 4]: mode ids; 6 or "6": the first 6
    skip_below_hz: float | None = None  # modes below this frequency (rigid-body modes) are left out
    grids: str | Sequence[int] | None = None  # "planform" (inside the CAERO1 panels), or ids ("101-140,150")
    units: str = "si"
    wtmass: float | None = None  # overrides PARAM,WTMASS for the structural mass

    def __post_init__(self) -> None:
        if self.units not in UNIT_SYSTEMS or self.units in _TIME_IN_MS:
            ok = [u for u in UNIT_SYSTEMS if u not in _TIME_IN_MS]
            raise InputError("units", f"must be one of {ok}, got {self.units!r}")
        if self.skip_below_hz is not None and not (math.isfinite(self.skip_below_hz) and self.skip_below_hz >= 0):
            raise InputError("skip_below_hz", f"must be a frequency >= 0 Hz, got {self.skip_below_hz!r}")
        if self.wtmass is not None and not (math.isfinite(self.wtmass) and self.wtmass > 0):
            raise InputError("wtmass", f"must be > 0, got {self.wtmass!r}")
        if self.subcase is not None and (isinstance(self.subcase, bool) or not isinstance(self.subcase, int)):
            raise InputError("subcase", f"must be an integer, got {self.subcase!r}")
        mode_selection(self.modes)
        grid_selection(self.grids)


def _id_list(text: str, field: str) -> list[int]:
    """Ids of "1,2,5-8" (ranges inclusive); InputError naming ``field``."""
    out: list[int] = []
    for part in (p.strip() for p in text.split(",")):
        m = re.fullmatch(r"(\d+)(?:\s*-\s*(\d+))?", part)
        if not m:
            raise InputError(field, f"{part!r} is not an id or a range a-b (give e.g. '1,2,4' or '101-140,150')")
        lo, hi = int(m.group(1)), int(m.group(2) or m.group(1))
        if hi < lo or hi - lo > 10_000_000:
            raise InputError(field, f"bad range {part!r}")
        out.extend(range(lo, hi + 1))
    return out


def mode_selection(value: str | int | Sequence[int] | None) -> tuple[str, list[int]]:
    """("all", []), ("count", [n]) or ("ids", [...]) from "6" / 6 (the first six) or "1,2,4" / [1, 2, 4]."""
    if value is None or (isinstance(value, str) and not value.strip()):
        return "all", []
    if isinstance(value, bool):
        raise InputError("modes", f"must be a count or a list of mode ids, got {value!r}")
    if isinstance(value, int):
        count = value
    elif isinstance(value, str) and value.strip().isdigit():
        count = int(value.strip())
    else:
        ids = _id_list(value, "modes") if isinstance(value, str) else [int(v) for v in value]
        if not ids or min(ids) < 1 or len(set(ids)) != len(ids):
            raise InputError("modes", f"mode ids must be distinct integers >= 1, got {value!r}")
        return "ids", ids
    if count < 1:
        raise InputError("modes", f"a mode count must be >= 1, got {count}")
    return "count", [count]


def grid_selection(value: str | Sequence[int] | None) -> str | set[int] | None:
    """None (all GRIDs), "planform" (GRIDs inside the CAERO1 panels) or a set of GRID ids."""
    if value is None or (isinstance(value, str) and not value.strip()):
        return None
    if isinstance(value, str):
        if value.strip().lower() == "planform":
            return "planform"
        return set(_id_list(value, "grids"))
    ids = {int(v) for v in value}
    if not ids:
        raise InputError("grids", "an empty GRID selection")
    return ids


def _read_op2(op2_file: Path) -> Any:
    """pyNastran OP2 results of ``op2_file``; InputError naming ``op2`` (file name only) when unreadable."""
    if not op2_file.is_file():
        raise InputError("op2", f"file {op2_file.name!r} not found")
    _, OP2 = import_pynastran()
    op2 = OP2(debug=None)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # np.chararray inside pyNastran 1.4.1
            op2.read_op2(str(op2_file), build_dataframe=False)
    except Exception as exc:
        reason = f"{type(exc).__name__}: {scrub(str(exc))[:300]}"
        raise InputError("op2", f"cannot read {op2_file.name} ({reason})") from None
    return op2


def _eigenvector_table(op2: Any, name: str, subcase: int | None) -> Any:
    """The real eigenvector table of the chosen subcase (the only one when ``subcase`` is None)."""
    vecs = {k: v for k, v in op2.eigenvectors.items() if getattr(v, "is_real", True)}
    if not vecs:
        raise InputError("op2", f"{name} holds no real eigenvectors (a SOL 103 run, or a SOL 145 run with "
                                "DISP output of its normal modes)")
    keys = sorted(vecs, key=str)
    shown = [int(k[0]) if isinstance(k, tuple) else int(k) for k in keys]
    if subcase is None:
        if len(keys) > 1:
            raise InputError("subcase", f"{name} has several eigenvector subcases {shown}; choose one")
        return vecs[keys[0]]
    match = [k for k in keys if k == subcase or (isinstance(k, tuple) and k[0] == subcase)]
    if not match:
        raise InputError("subcase", f"{subcase} not in {name} (has {shown})")
    return vecs[match[0]]


def _generalized_masses(op2: Any, modes: np.ndarray) -> np.ndarray | None:
    """Generalized masses [k] of mode ids ``modes`` from a real eigenvalue table, None when none lists them all."""
    for lama in op2.eigenvalues.values():
        if not getattr(lama, "is_real", False) or not hasattr(lama, "generalized_mass"):
            continue  # a complex (flutter) or buckling eigenvalue table
        lam_modes = np.asarray(lama.mode, dtype=int)
        if np.all(np.isin(modes, lam_modes)):
            order = {int(m): i for i, m in enumerate(lam_modes)}
            return np.asarray(lama.generalized_mass, dtype=float)[[order[int(m)] for m in modes]]
    return None


def _choose_modes(freqs: np.ndarray, mode_ids: np.ndarray, opts: NastranOptions, n_modes: int | None) -> np.ndarray:
    """Indices of the kept modes: rigid-body skip, then the id list or the first n."""
    keep = np.arange(freqs.size)
    if opts.skip_below_hz is not None:
        keep = keep[freqs >= opts.skip_below_hz]
        if keep.size == 0:
            raise InputError("skip_below_hz", f"no mode at or above {opts.skip_below_hz:g} Hz "
                                              f"(frequencies {np.round(freqs, 4).tolist()[:10]})")
    low = keep[freqs[keep] <= 0.0]
    if low.size:
        raise InputError("frequencies_hz", f"negative eigenvalues / zero frequencies {freqs[low].tolist()[:5]} Hz "
                                           "(rigid-body modes? leave them out with skip_below_hz, e.g. 0.5)")
    kind, vals = mode_selection(opts.modes)
    if kind == "ids":
        missing = sorted(set(vals) - {int(m) for m in mode_ids[keep]})
        if missing:
            raise InputError("modes", f"mode ids {missing[:10]} are not among the kept modes "
                                      f"{[int(m) for m in mode_ids[keep]][:30]}")
        pos = {int(m): i for i, m in zip(keep, mode_ids[keep], strict=True)}
        keep = np.array([pos[v] for v in vals])
    elif kind == "count":
        if vals[0] > keep.size:
            raise InputError("modes", f"asks for {vals[0]} modes; {keep.size} are available")
        keep = keep[:vals[0]]
    if n_modes is not None:
        if not 1 <= int(n_modes) <= keep.size:
            raise InputError("n_modes", f"must be in [1, {keep.size}], got {n_modes!r}")
        keep = keep[:int(n_modes)]
    return keep


def _grid_basic(model: Any, nids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Basic-frame positions [n, 3] (deck length unit) and output (CD) frame ids [n] of GRIDs ``nids``."""
    missing = [int(n) for n in nids if int(n) not in model.nodes]
    if missing:
        raise InputError("bdf", f"GRIDs {missing[:10]} of the OP2 eigenvectors are not in the BDF")
    nodes = [model.nodes[int(n)] for n in nids]
    xyz = np.array([nd.get_position() for nd in nodes], dtype=float).reshape(-1, 3)
    cd = np.array([int(nd.cd) for nd in nodes], dtype=int)
    return xyz, cd


def _grid_mask(model: Any, nids: np.ndarray, selection: str | set[int] | None) -> np.ndarray:
    """Which of the eigenvector GRIDs ``nids`` are kept: all, the listed ids, or those inside the CAERO1 panels."""
    if selection is None:
        return np.ones(nids.size, dtype=bool)
    if selection == "planform":
        from romams_core.nastran.caero import inside_panels, panel_corners

        corners = panel_corners(model, field="grids")
        xyz, _ = _grid_basic(model, nids)
        mask = inside_panels(xyz[:, :2], corners)
    else:
        assert isinstance(selection, set)
        mask = np.isin(nids, sorted(selection))
    if mask.sum() < 3:
        raise InputError("grids", f"the selection keeps {int(mask.sum())} GRIDs; at least 3 are needed")
    return mask


def _to_basic(model: Any, vec: np.ndarray, cd: np.ndarray) -> np.ndarray:
    """Rotate vectors [k, n, 3] from each GRID's rectangular output frame (CD) to the basic frame."""
    out = vec.copy()
    for cid in np.unique(cd[cd != 0]):  # a handful of coordinate systems
        rot = coord_rotation(model, int(cid), "bdf")
        sel = cd == cid
        out[:, sel, :] = vec[:, sel, :] @ rot
    return out


def _structural_mass(model: Any, wtmass: float | None) -> float | None:
    """Mass of the deck in its consistent units (WTMASS applied; ``wtmass`` overrides the PARAM), None if unknown."""
    try:
        from pyNastran.bdf.mesh_utils.mass_properties import mass_properties

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model.safe_cross_reference()
            mass = float(mass_properties(model, sym_axis="no")[0])  # the half wing, not mirrored by AERO
    except Exception:  # noqa: BLE001 - a partial deck (GRIDs only): no mass
        return None
    if wtmass is not None:
        mass *= wtmass / float(model.wtmass)
    return mass if math.isfinite(mass) and mass > 0 else None


def load_modes_nastran(bdf_path: PathLike, op2_path: PathLike, subcase: int | None = None,
                       n_modes: int | None = None, *, options: NastranOptions | None = None,
                       confine: bool = False) -> ExternalModes:
    """ExternalModes (SI) of a BDF + OP2 pair: real eigenvectors of one subcase, the chosen modes and GRIDs.

    ``subcase``/``n_modes``: shortcuts of ``options.subcase`` and a first-n cut after the selection.
    ``confine``: the deck's INCLUDEs must stay in its folder (uploads). Rotations R1, R2 (basic frame) travel
    with the shapes for the beam spline."""
    opts = options or NastranOptions()
    if subcase is not None:
        opts = dataclasses.replace(opts, subcase=subcase)
    bdf_file, op2_file = Path(bdf_path), Path(op2_path)
    if not op2_file.is_file():
        raise InputError("op2", f"file {op2_file.name!r} not found")
    model = read_bdf(bdf_file, confine=confine)
    if not model.nodes:
        raise InputError("bdf", f"{bdf_file.name} defines no GRID")
    op2 = _read_op2(op2_file)
    vec = _eigenvector_table(op2, op2_file.name, opts.subcase)
    data = np.asarray(vec.data, dtype=float)  # [k, n, 6]
    gridtype = np.asarray(vec.node_gridtype)
    is_grid = gridtype[:, 1] == 1  # GRID points only (no SPOINT/EPOINT)
    eigns = np.asarray(getattr(vec, "eigns", []), dtype=float)
    mode_ids = np.asarray(getattr(vec, "modes", np.arange(1, data.shape[0] + 1)), dtype=int)
    if eigns.size != data.shape[0]:
        raise InputError("op2", f"{eigns.size} eigenvalues for {data.shape[0]} eigenvectors")
    freqs = np.sign(eigns) * np.sqrt(np.abs(eigns)) / (2.0 * np.pi)
    keep = _choose_modes(freqs, mode_ids, opts, n_modes)
    nids = gridtype[is_grid, 0].astype(int)
    sel = _grid_mask(model, nids, grid_selection(opts.grids))
    nids = nids[sel]
    xyz, cd = _grid_basic(model, nids)
    t = _to_basic(model, data[keep][:, is_grid][:, sel, :3], cd)
    r = _to_basic(model, data[keep][:, is_grid][:, sel, 3:6], cd)
    length, mass_unit = UNIT_SYSTEMS[opts.units]
    gm = _generalized_masses(op2, mode_ids[keep])
    gm_scale = mass_unit * length ** 2  # generalized mass: mass x displacement^2 (or inertia x rotation^2)
    gm_si = (np.ones(keep.size) if gm is None else gm) * gm_scale
    mass = _structural_mass(model, opts.wtmass)
    return ExternalModes(
        nodes=xyz * length,
        shapes=t[:, :, 2].T * length,
        frequencies_hz=freqs[keep],
        generalized_masses=None if (gm is None and gm_scale == 1.0) else gm_si,
        mass_kg=None if mass is None else mass * mass_unit,
        source=op2_file.name,
        rotations=np.stack([r[:, :, 0].T, r[:, :, 1].T]),
        grid_ids=nids,
    )
