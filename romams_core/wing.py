"""Wing definitions: planform + parametric structure + named design variables with bounds.

A :class:`WingDefinition` holds the aerodynamic planform (fixed during optimization), a
parametric structure (:class:`PlateStructure` or :class:`BeamStructure`) and design variables.
Each :class:`DesignVariable` names a numeric field of the structure (``target``, a dotted path
such as ``"beam.height"``) and a ``scale`` that converts the user value to SI (``1e-3`` for a
value given in mm). ``design=None`` means the wing's baseline structure (``baseline`` if given,
else ``structure`` itself).

Units: SI (m, kg, Pa, kg/m^3); angles in radians.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from romams_core.errors import InputError
from romams_core.mesh import Planform
from romams_core.validation import check_int, check_number

THICKNESS_FORMS = ("constant", "naca4", "naca65a004")
#: aerodynamic symmetry about the root (x-z) plane: a half wing mirrored symmetrically, antisymmetrically, or
#: a free wing (no mirror); the DLM, the UVLM and the TSD model all three
SYMMETRIES = ("symmetric", "antisymmetric", "none")
BEAM_PLACEMENTS = ("mid-plane", "eccentric")


@dataclass(frozen=True)
class DesignVariable:
    """A named design variable: bounds in user units; ``target`` field gets ``value * scale`` (SI)."""

    name: str
    lower: float
    upper: float
    unit: str = ""
    description: str = ""
    target: str = ""
    scale: float = 1.0

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip():
            raise InputError("design_variable.name", "must be a non-empty string")
        where = f"design_variables.{self.name}"
        check_number(f"{where}.lower", self.lower)
        check_number(f"{where}.upper", self.upper)
        if not self.upper > self.lower:
            raise InputError(f"{where}.upper", f"must be > lower ({self.lower:g}), got {self.upper!r}")
        check_number(f"{where}.scale", self.scale)
        if self.scale == 0:
            raise InputError(f"{where}.scale", "must be non-zero")


@dataclass(frozen=True)
class PlateMaterial:
    """Orthotropic plate material (Pa, kg/m^3); axis 1 at ``orientation`` rad from +y (span) towards +x (aft)."""

    E1: float
    E2: float
    G12: float
    nu12: float
    density: float
    orientation: float = 0.0

    def __post_init__(self) -> None:
        for f in ("E1", "E2", "G12", "density"):
            check_number(f"material.{f}", getattr(self, f), 0.0)
        check_number("material.nu12", self.nu12)
        check_number("material.orientation", self.orientation)
        if self.nu12 ** 2 * self.E2 / self.E1 >= 1.0:
            raise InputError("material.nu12", f"nu12^2 E2/E1 must be < 1, got {self.nu12!r}")

    @classmethod
    def isotropic(cls, E: float, nu: float, density: float) -> PlateMaterial:
        """Isotropic material from Young's modulus (Pa), Poisson ratio and density (kg/m^3)."""
        check_number("material.E", E, 0.0)
        check_number("material.nu", nu)
        if not -1.0 < nu < 0.5:
            raise InputError("material.nu", f"must be in (-1, 0.5), got {nu!r}")
        return cls(E1=E, E2=E, G12=E / (2.0 * (1.0 + nu)), nu12=nu, density=density)

    def plane_stress_q(self) -> np.ndarray:
        """Reduced stiffness [3, 3] (Pa) in the x-y (chord-span) axes, engineering shear strain."""
        nu21 = self.nu12 * self.E2 / self.E1
        den = 1.0 - self.nu12 * nu21
        q11, q22, q12, q66 = self.E1 / den, self.E2 / den, self.nu12 * self.E2 / den, self.G12
        phi = 0.5 * math.pi - self.orientation  # angle of axis 1 from +x
        c, s = math.cos(phi), math.sin(phi)
        c2, s2 = c * c, s * s
        qb11 = q11 * c2 * c2 + 2 * (q12 + 2 * q66) * s2 * c2 + q22 * s2 * s2
        qb22 = q11 * s2 * s2 + 2 * (q12 + 2 * q66) * s2 * c2 + q22 * c2 * c2
        qb12 = (q11 + q22 - 4 * q66) * s2 * c2 + q12 * (s2 * s2 + c2 * c2)
        qb66 = (q11 + q22 - 2 * q12 - 2 * q66) * s2 * c2 + q66 * (s2 * s2 + c2 * c2)
        qb16 = (q11 - q12 - 2 * q66) * s * c * c2 + (q12 - q22 + 2 * q66) * s * s2 * c
        qb26 = (q11 - q12 - 2 * q66) * s * s2 * c + (q12 - q22 + 2 * q66) * s * c * c2
        return np.array([[qb11, qb12, qb16], [qb12, qb22, qb26], [qb16, qb26, qb66]])


@dataclass(frozen=True)
class StiffeningBeam:
    """Rectangular stiffening beam along a straight line root -> tip.

    ``root_position``: chord fraction of the root chord; ``tip_position``: chord fraction of the
    tip chord; ``height`` (m, vertical); width = ``width_ratio * height`` (m, in plane).
    ``placement``: ``"mid-plane"`` (centroid on the plate mid-plane: adds mass, little bending
    stiffness; the default, and what wings stored without the field mean) or ``"eccentric"``
    (glued to the plate's lower face, centroid (t_plate + height) / 2 below the mid-plane; the plate
    then gets membrane DOFs and the beam bends with the plate about the composite neutral axis).
    """

    material: PlateMaterial
    root_position: float
    tip_position: float
    height: float
    width_ratio: float = 1.0
    placement: str = "mid-plane"

    def __post_init__(self) -> None:
        for f in ("root_position", "tip_position"):
            v = getattr(self, f)
            check_number(f"structure.beam.{f}", v)
            if not 0.0 < v < 1.0:
                raise InputError(f"structure.beam.{f}", f"must be a chord fraction in (0, 1), got {v!r}")
        check_number("structure.beam.height", self.height, 0.0)
        check_number("structure.beam.width_ratio", self.width_ratio, 0.0)
        if self.placement not in BEAM_PLACEMENTS:
            raise InputError("structure.beam.placement", f"must be one of {BEAM_PLACEMENTS}, got {self.placement!r}")

    @property
    def width(self) -> float:
        """Section width (m)."""
        return self.height * self.width_ratio


@dataclass(frozen=True)
class LumpedMass:
    """Point mass (kg) at the leading edge at span fraction ``span_fraction``."""

    mass: float
    span_fraction: float

    def __post_init__(self) -> None:
        check_number("structure.lumped_mass.mass", self.mass, 0.0, strict=False)
        check_number("structure.lumped_mass.span_fraction", self.span_fraction)
        if not 0.0 <= self.span_fraction <= 1.0:
            raise InputError("structure.lumped_mass.span_fraction", f"must be in [0, 1], got {self.span_fraction!r}")


@dataclass(frozen=True)
class PlateStructure:
    """Thin plate (DKT elements) with optional stiffening beam and leading-edge lumped mass.

    Thickness (m): ``thickness_form == "constant"``: ``thickness``; ``"naca4"`` (symmetric NACA
    4-digit form) or ``"naca65a004"`` (tabulated NACA 65A004 form): the form scaled to
    ``thickness_to_chord * chord(y)`` at its maximum, floored at ``min_thickness_fraction`` of it.
    Either thickness is multiplied by ``thickness_ratio``.
    ``fe_n_chord`` x ``fe_n_span``: FE mesh quadrilateral cells (each split into two triangles).
    """

    material: PlateMaterial
    thickness: float = 1.0e-3
    thickness_form: str = "constant"
    thickness_to_chord: float = 0.04
    min_thickness_fraction: float = 0.05
    thickness_ratio: float = 1.0
    beam: StiffeningBeam | None = None
    lumped_mass: LumpedMass | None = None
    fe_n_chord: int = 12
    fe_n_span: int = 16
    kind: str = field(default="plate", init=False)

    def __post_init__(self) -> None:
        if not isinstance(self.material, PlateMaterial):
            raise InputError("structure.material", "must be a PlateMaterial")
        check_number("structure.thickness", self.thickness, 0.0)
        if self.thickness_form not in THICKNESS_FORMS:
            raise InputError("structure.thickness_form",
                             f"must be one of {THICKNESS_FORMS}, got {self.thickness_form!r}")
        check_number("structure.thickness_to_chord", self.thickness_to_chord, 0.0)
        check_number("structure.min_thickness_fraction", self.min_thickness_fraction, 0.0, strict=False)
        check_number("structure.thickness_ratio", self.thickness_ratio, 0.0)
        check_int("structure.fe_n_chord", self.fe_n_chord, 2, 200)
        check_int("structure.fe_n_span", self.fe_n_span, 2, 400)
        if self.beam is not None and not isinstance(self.beam, StiffeningBeam):
            raise InputError("structure.beam", "must be a StiffeningBeam or None")
        if self.lumped_mass is not None and not isinstance(self.lumped_mass, LumpedMass):
            raise InputError("structure.lumped_mass", "must be a LumpedMass or None")


@dataclass(frozen=True)
class BeamStructure:
    """Goland-type beam wing: bending + torsion beam on the elastic axis, rigid chordwise sections.

    EI, GJ (N m^2), mass per length (kg/m), torsional inertia about the elastic axis per length
    (kg m), elastic-axis and centre-of-gravity positions as chord fractions from the leading edge.
    """

    EI: float
    GJ: float
    mass_per_length: float
    inertia_ea_per_length: float
    ea_chord_fraction: float
    cg_chord_fraction: float
    n_elements: int = 20
    kind: str = field(default="beam", init=False)

    def __post_init__(self) -> None:
        for f in ("EI", "GJ", "mass_per_length", "inertia_ea_per_length"):
            check_number(f"structure.{f}", getattr(self, f), 0.0)
        for f in ("ea_chord_fraction", "cg_chord_fraction"):
            v = getattr(self, f)
            check_number(f"structure.{f}", v)
            if not 0.0 <= v <= 1.0:
                raise InputError(f"structure.{f}", f"must be a chord fraction in [0, 1], got {v!r}")
        check_int("structure.n_elements", self.n_elements, 1, 1000)


Structure = PlateStructure | BeamStructure


def _get_path(obj: Any, path: str) -> Any:
    """Value of a dotted attribute path (``"beam.height"``) on nested dataclasses."""
    for part in path.split("."):
        obj = getattr(obj, part)
    return obj


def _set_path(obj: Any, path: str, value: float) -> Any:
    """Copy of nested frozen dataclasses with the dotted field set to value."""
    head, _, rest = path.partition(".")
    if not rest:
        return dataclasses.replace(obj, **{head: value})
    return dataclasses.replace(obj, **{head: _set_path(getattr(obj, head), rest, value)})


@dataclass(frozen=True)
class WingDefinition:
    """A stored wing: name, planform, parametric structure, design variables, optional baseline.

    ``structure=None``: a planform-only wing, whose modes always come from outside (uploaded / Nastran).
    ``origin`` (m): where the planform's root leading edge lies in the frame of the model it was imported from
    (external nodes in that frame are moved by -origin); ``symmetry``: one of :data:`SYMMETRIES`;
    ``reference_chord`` (m): the source's reference chord (Nastran AERO REFC), recorded only (the solvers'
    reference chord is the root chord).
    """

    name: str
    planform: Planform
    structure: PlateStructure | BeamStructure | None
    design_variables: tuple[DesignVariable, ...] = ()
    baseline: PlateStructure | BeamStructure | None = None
    description: str = ""
    modal_damping: float = 0.0  # viscous modal damping ratio zeta applied to every mode in flutter analyses
    symmetry: str = "symmetric"
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    reference_chord: float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip():
            raise InputError("name", "must be a non-empty string")
        check_number("modal_damping", self.modal_damping, lower=0.0, strict=False)
        if self.modal_damping >= 1.0:
            raise InputError("modal_damping", f"must be a damping ratio in [0, 1), got {self.modal_damping!r}")
        if not isinstance(self.planform, Planform):
            raise InputError("planform", "must be a Planform")
        self._check_frame()
        if self.structure is None:
            if self.design_variables or self.baseline is not None:
                raise InputError("structure", "a planform-only wing (structure null) has no design variables or "
                                              "baseline")
            return
        if not isinstance(self.structure, PlateStructure | BeamStructure):
            raise InputError("structure", "must be a PlateStructure, a BeamStructure or null (planform only)")
        if self.planform.kinks:
            raise InputError("planform.kinks", "the built-in plate and beam structures are one trapezoid; a cranked "
                                               "planform is planform-only (structure null, modes from outside)")
        if self.baseline is not None and type(self.baseline) is not type(self.structure):
            raise InputError("baseline", "must be the same kind of structure as structure")
        object.__setattr__(self, "design_variables", tuple(self.design_variables))
        names = [v.name for v in self.design_variables]
        if len(set(names)) != len(names):
            raise InputError("design_variables", f"duplicate names in {names}")
        for v in self.design_variables:
            if not isinstance(v, DesignVariable):
                raise InputError("design_variables", "every entry must be a DesignVariable")
            try:
                current = _get_path(self.structure, v.target)
            except AttributeError:
                raise InputError(
                    f"design_variables.{v.name}.target", f"{v.target!r} is not a field of the structure "
                    "(give the parametric structure with its beam / lumped mass present)"
                ) from None
            if isinstance(current, bool) or not isinstance(current, int | float):
                raise InputError(f"design_variables.{v.name}.target", f"{v.target!r} is not a numeric field")
        if isinstance(self.structure, BeamStructure):
            s = self.structure
            chord = float(self.planform.root_chord)
            e = (s.cg_chord_fraction - s.ea_chord_fraction) * chord
            if s.mass_per_length * e * e >= s.inertia_ea_per_length:
                raise InputError("structure.inertia_ea_per_length", "must exceed mass_per_length * (CG offset)^2")

    def _check_frame(self) -> None:
        """Validate symmetry, origin and reference chord."""
        if self.symmetry not in SYMMETRIES:
            raise InputError("symmetry", f"must be one of {SYMMETRIES}, got {self.symmetry!r}")
        try:
            origin = tuple(float(v) for v in self.origin)
        except (TypeError, ValueError):
            raise InputError("origin", f"must be three numbers (m), got {self.origin!r}") from None
        if len(origin) != 3 or not all(math.isfinite(v) for v in origin):
            raise InputError("origin", f"must be three finite numbers (m), got {self.origin!r}")
        object.__setattr__(self, "origin", origin)
        if self.reference_chord is not None:
            check_number("reference_chord", self.reference_chord, 0.0)

    @property
    def has_baseline(self) -> bool:
        """True when ``design=None`` has a meaning (an explicit baseline, or no design variables)."""
        if self.structure is None:
            return False
        return self.baseline is not None or not self.design_variables

    @property
    def variable_names(self) -> list[str]:
        """Design variable names in vector order."""
        return [v.name for v in self.design_variables]

    def bounds(self) -> np.ndarray:
        """Design bounds [d, 2] (lower, upper) in user units."""
        return np.array([[v.lower, v.upper] for v in self.design_variables], dtype=float).reshape(-1, 2)

    def design_vector(self, design: Mapping[str, float] | Sequence[float] | np.ndarray | None) -> np.ndarray:
        """Validate a design (mapping by name or ordered sequence) -> vector [d] in user units."""
        dvs = self.design_variables
        if design is None or (isinstance(design, Mapping | Sequence | np.ndarray) and len(design) == 0):
            if dvs:
                raise InputError("design", f"values required for {', '.join(v.name for v in dvs)}")
            return np.zeros(0)
        if isinstance(design, Mapping):
            unknown = [k for k in design if k not in {v.name for v in dvs}]
            if unknown:
                raise InputError("design", f"unknown variable(s) {unknown}; known: {[v.name for v in dvs]}")
            missing = [v.name for v in dvs if v.name not in design]
            if missing:
                raise InputError("design", f"missing variable(s) {missing}")
            raw = [design[v.name] for v in dvs]
        else:
            raw = list(np.asarray(design, dtype=object).ravel()) if isinstance(design, np.ndarray) else list(design)
            if len(raw) != len(dvs):
                raise InputError("design", f"expected {len(dvs)} values ({[v.name for v in dvs]}), got {len(raw)}")
        out = np.empty(len(dvs))
        for i, (v, x) in enumerate(zip(dvs, raw, strict=True)):
            try:
                xf = float(x)
            except (TypeError, ValueError):
                raise InputError(f"design.{v.name}", f"must be a number, got {x!r}") from None
            if isinstance(x, bool) or not math.isfinite(xf):
                raise InputError(f"design.{v.name}", f"must be a finite number, got {x!r}")
            tol = 1e-12 * max(1.0, abs(v.lower), abs(v.upper))
            if not (v.lower - tol <= xf <= v.upper + tol):
                raise InputError(f"design.{v.name}",
                                 f"{xf:g} is outside its bounds [{v.lower:g}, {v.upper:g}] {v.unit}".rstrip())
            out[i] = min(max(xf, v.lower), v.upper)
        return out

    def structure_for(
        self, design: Mapping[str, float] | Sequence[float] | np.ndarray | None = None
    ) -> PlateStructure | BeamStructure:
        """The concrete structure of a design (None: the baseline)."""
        if self.structure is None:
            raise InputError("structure", f"wing {self.name!r} is planform-only (no built-in structure): give "
                                          "its modes from outside (a Nastran OP2, JSON or NPZ)")
        if design is None:
            if self.baseline is not None:
                return self.baseline
            if self.design_variables:
                raise InputError("design", f"wing {self.name!r} has no baseline; give values for its design variables")
            return self.structure
        x = self.design_vector(design)
        s = self.structure
        for v, xv in zip(self.design_variables, x, strict=True):
            s = _set_path(s, v.target, float(xv) * v.scale)
        return s

    def to_dict(self) -> dict[str, Any]:
        """JSON-able dictionary (SI units, radians) that :meth:`from_dict` reads back."""
        return {
            "name": self.name,
            "description": self.description,
            "planform": planform_dict(self.planform),
            "structure": None if self.structure is None else _structure_to_dict(self.structure),
            "baseline": None if self.baseline is None else _structure_to_dict(self.baseline),
            "design_variables": [dataclasses.asdict(v) for v in self.design_variables],
            "modal_damping": float(self.modal_damping),
            "symmetry": self.symmetry,
            "origin": list(self.origin),
            "reference_chord": self.reference_chord,
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> WingDefinition:
        """Inverse of :meth:`to_dict`; raises ValueError naming a missing or bad field."""
        if not isinstance(d, Mapping):
            raise InputError("wing", "must be a JSON object")
        for key in ("name", "planform"):
            if key not in d:
                raise InputError(key, "missing")
        try:
            planform = Planform(**dict(d["planform"]))
        except TypeError as exc:
            raise InputError("planform", str(exc)) from None
        try:
            dvs = tuple(DesignVariable(**dict(v)) for v in d.get("design_variables", []) or [])
        except TypeError as exc:
            raise InputError("design_variables", str(exc)) from None
        base = d.get("baseline")
        return cls(
            name=d["name"],
            planform=planform,
            structure=None if d.get("structure") is None else _structure_from_dict(d["structure"], "structure"),
            design_variables=dvs,
            baseline=None if base is None else _structure_from_dict(base, "baseline"),
            description=str(d.get("description", "")),
            modal_damping=d.get("modal_damping", 0.0),
            symmetry=d.get("symmetry", "symmetric"),
            origin=d.get("origin") or (0.0, 0.0, 0.0),
            reference_chord=d.get("reference_chord"),
        )


def planform_dict(planform: Planform) -> dict[str, Any]:
    """JSON-able planform (m, rad); ``kinks`` only when there are some (a trapezoid's dict is unchanged)."""
    d = dataclasses.asdict(planform)
    if planform.kinks:
        d["kinks"] = [list(k) for k in planform.kinks]
    else:
        d.pop("kinks")
    return d


def _structure_to_dict(s: PlateStructure | BeamStructure) -> dict[str, Any]:
    """JSON-able dict of a structure (nested dataclasses as dicts, with ``kind``)."""
    return dataclasses.asdict(s)


def _material_from(d: Mapping[str, Any], where: str) -> PlateMaterial:
    """PlateMaterial from a dict; ValueError naming ``where``."""
    try:
        return PlateMaterial(**dict(d))
    except TypeError as exc:
        raise InputError(where, str(exc)) from None


def _structure_from_dict(d: Mapping[str, Any], where: str) -> PlateStructure | BeamStructure:
    """Inverse of :func:`_structure_to_dict`."""
    if not isinstance(d, Mapping):
        raise InputError(where, "must be an object")
    d = dict(d)
    kind = d.pop("kind", None)
    try:
        if kind == "plate":
            d["material"] = _material_from(d["material"], f"{where}.material")
            if d.get("beam") is not None:
                b = dict(d["beam"])
                b["material"] = _material_from(b["material"], f"{where}.beam.material")
                d["beam"] = StiffeningBeam(**b)
            if d.get("lumped_mass") is not None:
                d["lumped_mass"] = LumpedMass(**dict(d["lumped_mass"]))
            return PlateStructure(**d)
        if kind == "beam":
            return BeamStructure(**d)
    except (TypeError, KeyError) as exc:
        raise InputError(where, str(exc)) from None
    raise InputError(f"{where}.kind", f"must be 'plate' or 'beam', got {kind!r}")


# --------------------------------------------------------------------------------------------
# Templates
# --------------------------------------------------------------------------------------------

ALUMINIUM = PlateMaterial.isotropic(E=70.0e9, nu=0.33, density=2700.0)

# Cropped delta calibration (docs/structure.md, benchmarks/calibrate_cropped_delta.py).
CROPPED_DELTA_ROOT_CHORD = 0.37336
CROPPED_DELTA_SEMISPAN_RATIO = 0.70
CROPPED_DELTA_TIP_RATIO = 0.2017
CROPPED_DELTA_SWEEP_LE_DEG = 42.927
CROPPED_DELTA_THICKNESS = 1.5161e-3


def cropped_delta(beam_placement: str = "mid-plane") -> WingDefinition:
    """The ROM-AMS paper's parameter-changeable cropped delta plate wing (Table 1 variables).

    ``beam_placement``: ``"mid-plane"`` (the template's default) or ``"eccentric"`` (the beam glued to the plate's
    face as in the paper's Fig. 5; its bending stiffness then includes the offset term EA d^2).
    """
    cr = CROPPED_DELTA_ROOT_CHORD
    planform = Planform(
        root_chord=cr,
        tip_chord=CROPPED_DELTA_TIP_RATIO * cr,
        semispan=CROPPED_DELTA_SEMISPAN_RATIO * cr,
        sweep_le=math.radians(CROPPED_DELTA_SWEEP_LE_DEG),
        n_chord=10,
        n_span=14,
    )
    plate = PlateStructure(
        material=ALUMINIUM,
        thickness=CROPPED_DELTA_THICKNESS,
        beam=StiffeningBeam(material=ALUMINIUM, root_position=0.4, tip_position=0.4, height=1.0e-3, width_ratio=1.0,
                            placement=beam_placement),
        lumped_mass=LumpedMass(mass=0.0, span_fraction=0.7),
        fe_n_chord=12,
        fe_n_span=16,
    )
    baseline = dataclasses.replace(plate, beam=None, lumped_mass=None, thickness_ratio=1.0)
    dvs = (
        DesignVariable("x1", 0.15, 0.70, "", "beam root-end position, fraction of root chord", "beam.root_position"),
        DesignVariable("x2", 0.15, 0.70, "", "beam tip-end position, fraction of tip chord", "beam.tip_position"),
        DesignVariable("x3", 0.60, 0.85, "", "lumped mass spanwise position (leading edge), fraction of span",
                       "lumped_mass.span_fraction"),
        DesignVariable("x4", 0.0, 0.105, "kg", "lumped mass", "lumped_mass.mass"),
        DesignVariable("x5", 0.5, 2.0, "mm", "beam section height", "beam.height", 1.0e-3),
        DesignVariable("x6", 0.5, 2.0, "", "beam section width, ratio of x5", "beam.width_ratio"),
        DesignVariable("x7", 0.5, 1.0, "", "plate thickness, ratio of the original", "thickness_ratio"),
    )
    return WingDefinition(
        name="cropped-delta",
        planform=planform,
        structure=plate,
        design_variables=dvs,
        baseline=baseline,
        description="Cantilevered aluminium cropped delta plate (Schairer & Hand model) with stiffening beam and "
        "leading-edge lumped mass; planform and thickness calibrated to 0.24 kg and 26.7/88.2/131.8 Hz.",
        modal_damping=0.0,  # no structural damping, as in the paper's flutter analyses
    )


def goland() -> WingDefinition:
    """The Goland wing: 6.096 m x 1.8288 m beam wing, EA 33% chord, CG 43% chord; no design variables."""
    planform = Planform(root_chord=1.8288, tip_chord=1.8288, semispan=6.096, sweep_le=0.0, n_chord=10, n_span=20)
    beam = BeamStructure(
        EI=9.77e6,
        GJ=0.99e6,
        mass_per_length=35.71,
        inertia_ea_per_length=8.64,
        ea_chord_fraction=0.33,
        cg_chord_fraction=0.43,
        n_elements=20,
    )
    return WingDefinition(
        name="goland",
        planform=planform,
        structure=beam,
        description="Goland (1945) cantilever wing, Euler-Bernoulli bending-torsion beam with CG offset; the "
        "standard mesh is 10 x 20 panels (the published SHARPy UVLM case uses 16 x 32).",
    )


def agard445() -> WingDefinition:
    """AGARD 445.6 weakened model 3: equivalent orthotropic plate with the NACA 65A004 thickness form.

    E1 = 3.151 GPa along the 45 deg quarter-chord line, E2 = 0.4162 GPa, nu12 = 0.31 (the equivalent-plate
    values of the published FE models); G12 = 0.340 GPa is identified from Yates' calculated modes 2-5
    instead of the published 0.4392 GPa, and the density (372.5 kg/m^3) is tuned so that mode 1 is Yates'
    9.60 Hz on this 16 x 20 mesh. With the published G12 the converged plate (checked against an
    independent Ritz solution) puts modes 2-5 5-7 % above Yates relative to mode 1, whatever the mesh,
    edge floor, E1 orientation or root clamp; those modes all move with the one ratio G12 / E1 (mode 1
    hardly depends on G12), so G12 is the constant they identify. Evidence in docs/structure.md and
    ``python -m benchmarks.agard_structure_study``. No design variables.
    """
    cr, ct, span = 0.5587, 0.3682, 0.762
    sweep_le = math.atan(math.tan(math.radians(45.0)) + (cr - ct) / (4.0 * span))
    planform = Planform(root_chord=cr, tip_chord=ct, semispan=span, sweep_le=sweep_le, n_chord=10, n_span=14)
    material = PlateMaterial(E1=3.151e9, E2=0.4162e9, G12=AGARD_G12, nu12=0.31, density=AGARD_DENSITY,
                             orientation=math.radians(45.0))
    plate = PlateStructure(material=material, thickness_form="naca65a004", thickness_to_chord=0.03994,
                           min_thickness_fraction=0.02, fe_n_chord=16, fe_n_span=20)
    return WingDefinition(
        name="agard-445.6",
        planform=planform,
        structure=plate,
        description="AGARD 445.6 weakened wing 3 as an equivalent orthotropic plate (E1 along the quarter-chord "
        "line) with NACA 65A004 thickness; in-plane shear modulus identified from Yates' modes 2-5 and density "
        "tuned to the first mode.",
    )


AGARD_G12 = 0.340e9  # Pa; identified from Yates' modes 2-5 (published equivalent-plate value: 0.4392e9)
AGARD_DENSITY = 372.5  # kg/m^3; mode 1 = 9.60 Hz on the 16 x 20 mesh (published FE models: about 382)

TEMPLATES = {"cropped-delta": cropped_delta, "goland": goland, "agard-445.6": agard445}


def template(name: str) -> WingDefinition:
    """A built-in wing by name ("cropped-delta", "goland", "agard-445.6")."""
    try:
        return TEMPLATES[name]()
    except KeyError:
        raise InputError("wing", f"unknown template {name!r}; known: {sorted(TEMPLATES)}") from None
