"""Wing planform (a trapezoid, or a cranked one) and the standard (aerodynamic) mesh on which all mode shapes live.

Conventions (used by every module of the core):
- x streamwise (aft positive), y spanwise (root at y = 0, tip at y = semispan), z up; metres.
- A planform is a trapezoid (root chord, tip chord, leading-edge sweep), or a cranked one: ``kinks`` adds
  interior span stations (y, leading-edge x, chord) and the leading edge and the chord are linear between them.
- The standard mesh is the corner-node grid of the aerodynamic panels: ``n_chord`` panels
  chordwise by ``n_span`` panels spanwise, nodes at equal chord fractions and, on a trapezoid, equal span
  fractions; on a cranked planform every kink is a node row and each segment between kinks gets its share of the
  ``n_span`` panels (in proportion to its span, at least one) at equal fractions of the segment.
  Node (i chordwise, j spanwise) has flat index ``j * (n_chord + 1) + i``.
- A mode shape "on the standard mesh" is the out-of-plane displacement w (m, or m per unit
  modal coordinate) at those N = (n_chord + 1) * (n_span + 1) nodes, shape [N] or [N, k].
- The reference chord ``c_ref`` is the root chord; nondimensional time is t* = t V / c_ref.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from romams_core.errors import InputError
from romams_core.validation import check_int, check_number


@dataclass(frozen=True)
class Planform:
    """Trapezoidal wing planform (m, rad) and the panel counts of its standard mesh."""

    root_chord: float
    tip_chord: float
    semispan: float
    sweep_le: float = 0.0  # leading-edge sweep, rad (positive: tip aft)
    n_chord: int = 10
    n_span: int = 16
    kinks: tuple[tuple[float, float, float], ...] = ()  # interior stations (y, leading-edge x, chord), m

    def __post_init__(self) -> None:
        check_number("planform.root_chord", self.root_chord, 0.0)
        check_number("planform.tip_chord", self.tip_chord, 0.0)
        check_number("planform.semispan", self.semispan, 0.0)
        if not (math.isfinite(self.sweep_le) and abs(self.sweep_le) < math.radians(80.0)):
            raise InputError("planform.sweep_le", f"must be finite with |sweep| < 80 deg, got {self.sweep_le!r} rad")
        for name in ("n_chord", "n_span"):
            check_int(f"planform.{name}", getattr(self, name), 1, 200)
        object.__setattr__(self, "kinks", _check_kinks(self.kinks, float(self.semispan)))
        if self.n_span < len(self.kinks) + 1:
            raise InputError("planform.n_span", f"a planform with {len(self.kinks)} kink(s) needs at least "
                                                f"{len(self.kinks) + 1} span panels, got {self.n_span}")

    @property
    def stations(self) -> np.ndarray:
        """[S, 3] span stations (y, leading-edge x, chord), m, from root to tip (kinks in between)."""
        root = (0.0, 0.0, float(self.root_chord))
        tip = (float(self.semispan), float(self.semispan) * math.tan(self.sweep_le), float(self.tip_chord))
        return np.array([root, *self.kinks, tip], dtype=float)

    def eta_nodes(self) -> np.ndarray:
        """[n_span + 1] span fractions of the standard mesh's node rows (the kinks among them)."""
        if not self.kinks:
            return np.linspace(0.0, 1.0, self.n_span + 1)
        st = self.stations
        eta_k = st[:, 0] / self.semispan
        counts = _share(np.diff(eta_k), self.n_span)
        parts = [np.linspace(a, b, n + 1)[:-1] for a, b, n in zip(eta_k[:-1], eta_k[1:], counts, strict=True)]
        return np.concatenate([*parts, [1.0]])

    @property
    def c_ref(self) -> float:
        """Reference chord (m): the root chord."""
        return float(self.root_chord)

    @property
    def area(self) -> float:
        """Planform area of the half wing (m^2)."""
        st = self.stations
        return float(np.sum(0.5 * (st[1:, 2] + st[:-1, 2]) * np.diff(st[:, 0])))

    def x_le(self, y: np.ndarray | float) -> np.ndarray:
        """Leading-edge x (m) at span station y (m); linear beyond root and tip."""
        if not self.kinks:
            return np.asarray(y, dtype=float) * math.tan(self.sweep_le)
        st = self.stations
        return piecewise_linear(np.asarray(y, dtype=float), st[:, 0], st[:, 1])

    def chord(self, y: np.ndarray | float) -> np.ndarray:
        """Local chord (m) at span station y (m); linear beyond root and tip."""
        if not self.kinks:
            eta = np.asarray(y, dtype=float) / self.semispan
            return self.root_chord + (self.tip_chord - self.root_chord) * eta
        st = self.stations
        return piecewise_linear(np.asarray(y, dtype=float), st[:, 0], st[:, 2])

    def to_xy(self, xi: np.ndarray, eta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Map chord fraction xi and span fraction eta (both 0..1) to physical x, y (m)."""
        y = np.asarray(eta, dtype=float) * self.semispan
        x = self.x_le(y) + np.asarray(xi, dtype=float) * self.chord(y)
        return x, y

    def to_xi_eta(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Inverse of :meth:`to_xy`: chord and span fractions of physical points (m)."""
        y = np.asarray(y, dtype=float)
        eta = y / self.semispan
        xi = (np.asarray(x, dtype=float) - self.x_le(y)) / self.chord(y)
        return xi, eta


@dataclass(frozen=True)
class StandardMesh:
    """Corner nodes (m) and quadrilateral panels of the standard aerodynamic mesh."""

    planform: Planform
    x: np.ndarray = field(repr=False)  # [N] node x, m
    y: np.ndarray = field(repr=False)  # [N] node y, m
    panels: np.ndarray = field(repr=False)  # [n_chord * n_span, 4] node indices, counter-clockwise from (i, j)

    @property
    def n_chord(self) -> int:
        """Chordwise panel count."""
        return self.planform.n_chord

    @property
    def n_span(self) -> int:
        """Spanwise panel count."""
        return self.planform.n_span

    @property
    def n_nodes(self) -> int:
        """Number of nodes N."""
        return int(self.x.size)

    @property
    def c_ref(self) -> float:
        """Reference chord (m)."""
        return self.planform.c_ref

    @property
    def nodes(self) -> np.ndarray:
        """Node coordinates [N, 3] (m), z = 0."""
        return np.column_stack([self.x, self.y, np.zeros_like(self.x)])

    def grid(self, values: np.ndarray) -> np.ndarray:
        """Reshape nodal values [N, ...] to [n_span + 1, n_chord + 1, ...]."""
        values = np.asarray(values)
        return values.reshape((self.n_span + 1, self.n_chord + 1) + values.shape[1:])

    @property
    def eta(self) -> np.ndarray:
        """[n_span + 1] span fractions of the node rows."""
        return self.grid(self.y)[:, 0] / self.planform.semispan


def _check_kinks(kinks: object, semispan: float) -> tuple[tuple[float, float, float], ...]:
    """Kinks as a tuple of (y, x_le, chord) floats (m): 0 < y < semispan increasing, chord > 0 (InputError)."""
    try:
        rows = [tuple(k) for k in kinks]  # type: ignore[attr-defined]
    except TypeError:
        raise InputError("planform.kinks", f"must be a list of [y, x_le, chord] triples, got {kinks!r}") from None
    out: list[tuple[float, float, float]] = []
    for n, row in enumerate(rows):
        if len(row) != 3:
            raise InputError(f"planform.kinks[{n}]", f"must be [y, x_le, chord] (m), got {list(row)!r}")
        y = check_number(f"planform.kinks[{n}].y", row[0], 0.0, upper=semispan)
        x = check_number(f"planform.kinks[{n}].x_le", row[1])
        c = check_number(f"planform.kinks[{n}].chord", row[2], 0.0)
        if out and y <= out[-1][0] * (1 + 1e-12):
            raise InputError(f"planform.kinks[{n}].y", f"kinks must be in increasing y, got {y!r} after {out[-1][0]!r}")
        out.append((y, x, c))
    return tuple(out)


def _share(fractions: np.ndarray, n: int) -> np.ndarray:
    """Integer counts (each >= 1, summing to n) in proportion to ``fractions`` (largest remainders)."""
    extra = n - fractions.size
    want = fractions / fractions.sum() * extra
    counts = np.floor(want).astype(int)
    order = np.argsort(-(want - counts), kind="stable")
    counts[order[: extra - int(counts.sum())]] += 1
    return counts + 1


def piecewise_linear(y: np.ndarray, ys: np.ndarray, vs: np.ndarray) -> np.ndarray:
    """Values at ``y`` of the polyline (ys, vs), continued linearly beyond its ends (ys increasing)."""
    out = np.interp(y, ys, vs)
    lo, hi = y < ys[0], y > ys[-1]
    s0 = (vs[1] - vs[0]) / (ys[1] - ys[0])
    s1 = (vs[-1] - vs[-2]) / (ys[-1] - ys[-2])
    return np.where(lo, vs[0] + s0 * (y - ys[0]), np.where(hi, vs[-1] + s1 * (y - ys[-1]), out))


def standard_mesh(planform: Planform, eta_nodes: np.ndarray | None = None) -> StandardMesh:
    """Build the standard mesh of a planform: nodes at equal chord fractions and the planform's span fractions
    (``eta_nodes`` [n_span + 1] to give them; m)."""
    nc, ns = planform.n_chord, planform.n_span
    eta_rows = planform.eta_nodes() if eta_nodes is None else np.asarray(eta_nodes, dtype=float)
    if eta_rows.shape != (ns + 1,):
        raise InputError("eta_nodes", f"expected {ns + 1} span fractions, got shape {eta_rows.shape}")
    xi, eta = np.meshgrid(np.linspace(0.0, 1.0, nc + 1), eta_rows)
    x, y = planform.to_xy(xi.ravel(), eta.ravel())
    i, j = np.meshgrid(np.arange(nc), np.arange(ns))
    n0 = (j * (nc + 1) + i).ravel()
    panels = np.column_stack([n0, n0 + 1, n0 + nc + 2, n0 + nc + 1])
    return StandardMesh(planform=planform, x=x, y=y, panels=panels)


def refined_mesh(mesh: StandardMesh, factor: int) -> StandardMesh:
    """The mesh with every panel split ``factor`` x ``factor`` (equal parts of each panel; m)."""
    pf = mesh.planform
    fine = dataclasses.replace(pf, n_chord=pf.n_chord * factor, n_span=pf.n_span * factor)
    eta = mesh.eta  # the mesh's own rows (kinks, or rows given to standard_mesh), not the planform's default
    fine_eta = np.concatenate([eta[:-1, None] + np.diff(eta)[:, None] * (np.arange(factor) / factor)[None, :],
                               [[1.0]]], axis=None)
    return standard_mesh(fine, fine_eta)
