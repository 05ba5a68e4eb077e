"""The wing planform of a Nastran deck: CAERO1 panels, their box divisions, AERO / AEROS reference and symmetry.

CAERO1 panels are merged into the one planform of the standard mesh: panels side by side chordwise (a wing
box and its control-surface panel) join into one strip, strips join spanwise (several trapezoids along the
span). Where the leading edge or the chord bends between strips, the planform gets a kink there (a cranked
planform, ``Planform.kinks``); strips on one straight trapezoid merge into it. The root leading edge need not
be at the origin: the planform is translated there and the offset recorded (``origin``, in metres in the deck's
basic frame). Dihedral is projected away (the standard mesh is flat). Box counts: NSPAN/NCHORD, or the AEFACT
lists of LSPAN/LCHORD (n + 1 fractions -> n boxes; the standard mesh uses equal fractions). Structural damping: the
TABDMP1 table (SDAMP) as the wing's modal damping ratio.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from romams_core.errors import InputError
from romams_core.mesh import Planform
from romams_core.nastran.deck import PathLike, coord_rotation, read_bdf
from romams_core.nastran.op2 import UNIT_SYSTEMS, NastranOptions
from romams_core.wing import WingDefinition

_SYMXZ = {1: "symmetric", -1: "antisymmetric", 0: "none"}
_MAX_BOXES = 200


@dataclass(frozen=True)
class DeckPlanform:
    """A deck's planform in SI: the trapezoid, its offset, symmetry, reference chord and what was read."""

    planform: Planform
    origin: tuple[float, float, float]  # root leading edge in the deck's basic frame, m
    symmetry: str
    reference_chord: float | None  # AERO / AEROS REFC, m
    n_panels: int
    notes: list[str] = field(default_factory=list)


def _point(model: Any, cp: int, xyz: Any) -> np.ndarray:
    """A point given in coordinate system ``cp`` -> basic frame."""
    if int(cp) == 0:
        return np.asarray(xyz, dtype=float)
    coord = model.coords.get(int(cp))
    if coord is None:
        raise InputError("caero1", f"coordinate system CP={cp} is not defined")
    return np.asarray(coord.transform_node_to_global(np.asarray(xyz, dtype=float)), dtype=float)


def _aero_card(model: Any) -> Any:
    """The AERO card (flutter) if present, else AEROS (static aeroelasticity), else None."""
    return getattr(model, "aero", None) or getattr(model, "aeros", None)


def panel_corners(model: Any, field: str = "caero1") -> np.ndarray:
    """Corners [n, 4, 3] (p1 root LE, p2 root TE, p3 tip TE, p4 tip LE; basic frame, deck units) of the CAERO1s."""
    caeros = [c for c in model.caeros.values() if c.type == "CAERO1"]
    if not caeros:
        raise InputError(field, "the deck has no CAERO1 panel")
    aero = _aero_card(model)
    acsid = int(getattr(aero, "acsid", 0) or 0) if aero is not None else 0
    axes = coord_rotation(model, acsid, "caero1")
    if not np.allclose(axes, np.eye(3), atol=1e-9):
        raise InputError("caero1", f"the aerodynamic coordinate system ACSID={acsid} is rotated from the basic "
                                   "frame; only ACSID axes parallel to basic are supported")
    out = []
    for c in sorted(caeros, key=lambda c: c.eid):
        p1, p4 = _point(model, c.cp, c.p1), _point(model, c.cp, c.p4)
        out.append([p1, p1 + [c.x12, 0.0, 0.0], p4 + [c.x43, 0.0, 0.0], p4])
    return np.asarray(out, dtype=float)


def inside_panels(points_xy: np.ndarray, corners: np.ndarray, tol: float = 1e-6) -> np.ndarray:
    """Which points [P, 2] lie inside (or within ``tol`` x size on the edge of) any panel [n, 4, 3], in plan view."""
    pts = np.asarray(points_xy, dtype=float)
    quads = corners[:, :, :2]
    size = float(np.ptp(quads.reshape(-1, 2), axis=0).max())
    inside = np.zeros(pts.shape[0], dtype=bool)
    for q in quads:  # convex quadrilaterals: the point is on the same side of every edge
        edges = np.roll(q, -1, axis=0) - q
        rel = pts[:, None, :] - q[None, :, :]
        cross = edges[None, :, 0] * rel[:, :, 1] - edges[None, :, 1] * rel[:, :, 0]
        sign = np.sign(np.sum(edges[:, 0] * np.roll(edges, -1, axis=0)[:, 1]
                              - edges[:, 1] * np.roll(edges, -1, axis=0)[:, 0]))
        inside |= np.all(sign * cross / np.linalg.norm(edges, axis=1)[None, :] >= -tol * size, axis=1)
    return inside


def _boxes(model: Any, c: Any, n: int, lref: int, what: str) -> tuple[int, bool]:
    """Box count of one direction of a CAERO1 (from N or the AEFACT L) and whether the division is uniform."""
    if int(n or 0) > 0:
        return int(n), True
    fact = model.aefacts.get(int(lref or 0))
    if fact is None:
        raise InputError("caero1", f"CAERO1 {c.eid}: no {what} division (N{what} = 0 and AEFACT {lref} missing)")
    f = np.asarray(fact.fractions, dtype=float)
    if f.size < 2 or np.any(np.diff(f) <= 0):
        raise InputError("caero1", f"AEFACT {lref} of CAERO1 {c.eid} must increase and hold >= 2 fractions")
    return int(f.size - 1), bool(np.allclose(np.diff(f), np.diff(f).mean(), rtol=1e-6))


def _strips(corners: np.ndarray, tol: float) -> list[np.ndarray]:
    """Merge chordwise neighbours (same span edges) into strips [4, 3], sorted root to tip."""
    groups: dict[tuple[float, float], list[np.ndarray]] = {}
    for q in corners:
        key = (round(q[0, 1] / tol), round(q[3, 1] / tol))
        groups.setdefault(key, []).append(q)
    strips = []
    for qs in groups.values():
        qs = sorted(qs, key=lambda q: q[0, 0])
        for a, b in zip(qs, qs[1:], strict=False):
            if not (np.allclose(a[1], b[0], atol=tol) and np.allclose(a[2], b[3], atol=tol)):
                raise InputError("caero1", "CAERO1 panels at the same span stations do not join chordwise "
                                           "(trailing edge of one = leading edge of the next)")
        strips.append(np.array([qs[0][0], qs[-1][1], qs[-1][2], qs[0][3]]))
    return sorted(strips, key=lambda q: q[0, 1])


def _stations(strips: list[np.ndarray], tol: float) -> np.ndarray:
    """Span stations [S, 3] (y, leading-edge x, chord; deck units) of strips joined spanwise: the root, every
    interior strip edge where the leading edge or the chord bends (a kink), the tip."""
    for a, b in zip(strips, strips[1:], strict=False):
        if not (np.allclose(a[3], b[0], atol=tol) and np.allclose(a[2], b[1], atol=tol)):
            raise InputError("caero1", "the CAERO1 panels do not join spanwise (tip edge of one = root edge of the "
                                       "next); a wing with gaps or overlaps cannot be one standard mesh")
    edges = [(q[0, 1], q[0, 0], q[1, 0] - q[0, 0]) for q in strips] + [
        (strips[-1][3, 1], strips[-1][3, 0], strips[-1][2, 0] - strips[-1][3, 0])]
    pts = np.array(edges, dtype=float)
    if pts[-1, 0] - pts[0, 0] <= 0:
        raise InputError("caero1", "the panels' tips lie at smaller y than their roots (a left wing?); give the "
                                   "right half wing (y from root to tip increasing)")
    keep = [0]
    for n in range(1, len(pts) - 1):  # drop an edge on the straight line from the last kept station to the next
        a, b, c = pts[keep[-1]], pts[n], pts[n + 1]
        lin = a[1:] + (b[0] - a[0]) / (c[0] - a[0]) * (c[1:] - a[1:])
        if np.abs(b[1:] - lin).max() > tol * 10:
            keep.append(n)
    return pts[keep + [len(pts) - 1]]


def planform_from_model(model: Any, units: str = "si", n_chord: int | None = None,
                        n_span: int | None = None) -> DeckPlanform:
    """The planform (SI) of a pyNastran model's CAERO1 panels with its AERO / AEROS data."""
    length = UNIT_SYSTEMS[NastranOptions(units=units).units][0]
    corners = panel_corners(model)
    tol = 1e-4 * float(np.ptp(corners[:, :, :2].reshape(-1, 2), axis=0).max())
    notes: list[str] = []
    strips = _strips(corners, tol)
    st = _stations(strips, tol)
    le = strips[0][0]
    semispan = float(st[-1, 0] - st[0, 0])
    sweep = math.atan2(float(st[-1, 1] - st[0, 1]), semispan)
    kinks = tuple((float(y - st[0, 0]) * length, float(x - st[0, 1]) * length, float(c) * length)
                  for y, x, c in st[1:-1])
    if kinks:
        notes.append(f"cranked planform: {len(kinks)} kink(s) at y = "
                     + ", ".join(f"{k[0]:.4g}" for k in kinks) + " m")
    dz = float(np.ptp(corners[:, :, 2]))
    if dz > 1e-3 * semispan:
        notes.append(f"dihedral / camber of {dz * length:.4g} m in z projected onto the x-y plane")
    caeros = sorted((c for c in model.caeros.values() if c.type == "CAERO1"), key=lambda c: c.eid)
    spans = {round(float(q[0, 1]) / tol): c for c, q in zip(caeros, corners, strict=True)}
    span_boxes = [_boxes(model, c, c.nspan, c.lspan, "SPAN") for c in spans.values()]
    chord_boxes = [_boxes(model, c, c.nchord, c.lchord, "CHORD") for c in caeros]
    if not all(u for _, u in span_boxes + chord_boxes):
        notes.append("non-uniform AEFACT divisions replaced by equal fractions on the standard mesh")
    ns = n_span or min(_MAX_BOXES, sum(n for n, _ in span_boxes))
    nc = n_chord or min(_MAX_BOXES, max(n for n, _ in chord_boxes))
    aero = _aero_card(model)
    symmetry, cref = "symmetric", None
    if aero is None:
        notes.append("no AERO / AEROS card: symmetric about the root assumed")
    else:
        symmetry = _SYMXZ.get(int(getattr(aero, "sym_xz", 0) or 0), "none")
        if int(getattr(aero, "sym_xy", 0) or 0) != 0:
            raise InputError("symmetry", f"{aero.type} SYMXY = {aero.sym_xy} (mirror about the x-y plane, ground "
                                         "effect) is not supported")
        cref = float(aero.cref) * length if getattr(aero, "cref", None) else None
    ns = max(int(ns), len(kinks) + 1)
    planform = Planform(root_chord=float(st[0, 2]) * length, tip_chord=float(st[-1, 2]) * length,
                        semispan=semispan * length, sweep_le=sweep, n_chord=int(nc), n_span=ns, kinks=kinks)
    origin = tuple(float(v) * length for v in le)
    return DeckPlanform(planform, (origin[0], origin[1], origin[2]), symmetry, cref, len(caeros), notes)


def modal_damping(model: Any) -> tuple[float | None, str]:
    """Viscous modal damping ratio of a deck's TABDMP1 (the SDAMP table of the case control, else the only one)
    and a note: G -> g / 2, CRIT -> zeta, Q -> 1 / (2 Q); a table varying with frequency gives its smallest
    ratio (the conservative one for flutter). (None, "") without a table."""
    tables = getattr(model, "tables_sdamping", {}) or {}
    tid = None
    deck = getattr(model, "case_control_deck", None)
    for sub in (getattr(deck, "subcases", {}) or {}).values():
        keys = [k for k in getattr(sub, "params", {}) if str(k).upper().startswith("SDAMP")]
        if keys:
            try:
                tid = int(sub.params[keys[0]][0])
            except (TypeError, ValueError, IndexError):
                raise InputError("sdamp", f"SDAMP = {sub.params[keys[0]][0]!r} is not a table id") from None
            break
    table = tables.get(tid) if tid is not None else (next(iter(tables.values())) if len(tables) == 1 else None)
    if table is None:
        return None, ""
    y = np.asarray(table.y, dtype=float)
    kind = str(table.Type).upper()
    zeta = {"G": y / 2.0, "CRIT": y, "Q": 1.0 / (2.0 * np.where(y > 0, y, np.inf))}.get(kind)
    if zeta is None or zeta.size == 0 or not np.all(np.isfinite(zeta)) or zeta.min() < 0 or zeta.max() >= 1:
        raise InputError("tabdmp1", f"TABDMP1 {table.tid}: unusable {kind} damping values {y.tolist()[:6]}")
    note = f"modal damping from TABDMP1 {table.tid} ({kind})"
    if np.ptp(zeta) > 1e-12:
        note += f", varying with frequency: its smallest ratio {zeta.min():.4g} taken"
    return float(zeta.min()), note


def wing_from_bdf(bdf_path: PathLike, name: str | None = None, *, units: str = "si", symmetry: str | None = None,
                  n_chord: int | None = None, n_span: int | None = None, confine: bool = False) -> WingDefinition:
    """A planform-only WingDefinition from a deck's CAERO1 / AERO(S) cards (modes then come from its OP2).

    ``symmetry`` overrides the deck's (e.g. "symmetric" to analyse the symmetric case of an antisymmetric deck)."""
    from pathlib import Path

    path = Path(bdf_path)
    model = read_bdf(path, confine=confine)
    dp = planform_from_model(model, units, n_chord, n_span)
    zeta, damping_note = modal_damping(model)
    if damping_note:
        dp.notes.append(damping_note)
    sym = symmetry or dp.symmetry  # the deck's AERO/AEROS SYMXZ (checked by WingDefinition)
    notes = "; ".join(dp.notes)
    return WingDefinition(
        name=name or path.stem, planform=dp.planform, structure=None, symmetry=sym, origin=dp.origin,
        reference_chord=dp.reference_chord, modal_damping=zeta or 0.0,
        description=f"Imported from {path.name}: {dp.n_panels} CAERO1 panel(s), root leading edge at "
                    f"({', '.join(f'{v:.6g}' for v in dp.origin)}) m" + (f"; {notes}" if notes else ""),
    )
