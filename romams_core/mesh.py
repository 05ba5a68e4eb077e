"""Trapezoidal planform and the standard (aerodynamic) mesh on which all mode shapes live.

Conventions (used by every module of the core):
- x streamwise (aft positive), y spanwise (root at y = 0, tip at y = semispan), z up; metres.
- The standard mesh is the corner-node grid of the aerodynamic panels: ``n_chord`` panels
  chordwise by ``n_span`` panels spanwise, nodes at equal chord fractions and equal span
  fractions. Node (i chordwise, j spanwise) has flat index ``j * (n_chord + 1) + i``.
- A mode shape "on the standard mesh" is the out-of-plane displacement w (m, or m per unit
  modal coordinate) at those N = (n_chord + 1) * (n_span + 1) nodes, shape [N] or [N, k].
- The reference chord ``c_ref`` is the root chord; nondimensional time is t* = t V / c_ref.
"""

from __future__ import annotations

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

    def __post_init__(self) -> None:
        check_number("planform.root_chord", self.root_chord, 0.0)
        check_number("planform.tip_chord", self.tip_chord, 0.0)
        check_number("planform.semispan", self.semispan, 0.0)
        if not (math.isfinite(self.sweep_le) and abs(self.sweep_le) < math.radians(80.0)):
            raise InputError("planform.sweep_le", f"must be finite with |sweep| < 80 deg, got {self.sweep_le!r} rad")
        for name in ("n_chord", "n_span"):
            check_int(f"planform.{name}", getattr(self, name), 1, 200)

    @property
    def c_ref(self) -> float:
        """Reference chord (m): the root chord."""
        return float(self.root_chord)

    @property
    def area(self) -> float:
        """Planform area of the half wing (m^2)."""
        return 0.5 * (self.root_chord + self.tip_chord) * self.semispan

    def x_le(self, y: np.ndarray | float) -> np.ndarray:
        """Leading-edge x (m) at span station y (m)."""
        return np.asarray(y, dtype=float) * math.tan(self.sweep_le)

    def chord(self, y: np.ndarray | float) -> np.ndarray:
        """Local chord (m) at span station y (m)."""
        eta = np.asarray(y, dtype=float) / self.semispan
        return self.root_chord + (self.tip_chord - self.root_chord) * eta

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


def standard_mesh(planform: Planform) -> StandardMesh:
    """Build the standard mesh of a planform: nodes at equal chord and span fractions (m)."""
    nc, ns = planform.n_chord, planform.n_span
    xi, eta = np.meshgrid(np.linspace(0.0, 1.0, nc + 1), np.linspace(0.0, 1.0, ns + 1))
    x, y = planform.to_xy(xi.ravel(), eta.ravel())
    i, j = np.meshgrid(np.arange(nc), np.arange(ns))
    n0 = (j * (nc + 1) + i).ravel()
    panels = np.column_stack([n0, n0 + 1, n0 + nc + 2, n0 + nc + 1])
    return StandardMesh(planform=planform, x=x, y=y, panels=panels)
