"""Wing definitions: validation, design vectors, JSON round trip, templates."""

import dataclasses
import json
import math

import numpy as np
import pytest

from romams_core.mesh import Planform
from romams_core.wing import (
    TEMPLATES,
    BeamStructure,
    DesignVariable,
    LumpedMass,
    PlateMaterial,
    PlateStructure,
    StiffeningBeam,
    WingDefinition,
    template,
)

GOOD = {"x1": 0.3, "x2": 0.5, "x3": 0.7, "x4": 0.05, "x5": 1.0, "x6": 1.0, "x7": 0.8}


def test_cropped_delta_template_has_table1_variables_and_bounds():
    w = template("cropped-delta")
    assert w.variable_names == ["x1", "x2", "x3", "x4", "x5", "x6", "x7"]
    np.testing.assert_allclose(
        w.bounds(), [[0.15, 0.7], [0.15, 0.7], [0.6, 0.85], [0.0, 0.105], [0.5, 2.0], [0.5, 2.0], [0.5, 1.0]]
    )
    assert w.has_baseline
    base = w.structure_for(None)
    assert base.beam is None and base.lumped_mass is None and base.thickness_ratio == 1.0


def test_design_vector_by_mapping_and_sequence_agree():
    w = template("cropped-delta")
    v1 = w.design_vector(GOOD)
    v2 = w.design_vector([GOOD[k] for k in w.variable_names])
    np.testing.assert_array_equal(v1, v2)
    np.testing.assert_array_equal(v1, [0.3, 0.5, 0.7, 0.05, 1.0, 1.0, 0.8])


def test_structure_for_applies_scales_and_targets():
    s = template("cropped-delta").structure_for(GOOD)
    assert s.beam.root_position == 0.3 and s.beam.tip_position == 0.5
    assert s.lumped_mass.span_fraction == 0.7 and s.lumped_mass.mass == 0.05
    assert math.isclose(s.beam.height, 1.0e-3) and math.isclose(s.beam.width, 1.0e-3)
    assert s.thickness_ratio == 0.8


@pytest.mark.parametrize(
    ("design", "match"),
    [
        ({**GOOD, "x1": 0.9}, r"x1: 0.9 is outside its bounds \[0.15, 0.7\]"),
        ({**GOOD, "x4": -0.01}, r"x4: .* outside its bounds \[0, 0.105\] kg"),
        ({**GOOD, "x5": float("nan")}, "x5: must be a finite number"),
        ({**GOOD, "x6": float("inf")}, "x6: must be a finite number"),
        ({**GOOD, "x8": 1.0}, r"unknown variable\(s\) \['x8'\]"),
        ({k: v for k, v in GOOD.items() if k != "x3"}, r"missing variable\(s\) \['x3'\]"),
        ([0.3, 0.5, 0.7], "expected 7 values"),
        ({**GOOD, "x2": "abc"}, "x2: must be a number"),
        (None, "design: values required"),
    ],
)
def test_bad_designs_raise_value_error_naming_the_field(design, match):
    with pytest.raises(ValueError, match=match):
        template("cropped-delta").design_vector(design)


def test_goland_has_no_design_variables_and_accepts_none_or_empty():
    w = template("goland")
    assert w.design_variables == () and w.has_baseline
    assert w.design_vector(None).shape == (0,)
    assert w.design_vector({}).shape == (0,)
    assert w.design_vector([]).shape == (0,)
    with pytest.raises(ValueError, match="expected 0 values"):
        w.design_vector([1.0])


@pytest.mark.parametrize("name", sorted(TEMPLATES))
def test_to_dict_from_dict_round_trip_through_json(name):
    w = template(name)
    d = json.loads(json.dumps(w.to_dict()))
    w2 = WingDefinition.from_dict(d)
    assert w2 == w
    assert w2.to_dict() == w.to_dict()


def test_unknown_template_raises():
    with pytest.raises(ValueError, match="unknown template 'nope'"):
        template("nope")


@pytest.mark.parametrize(
    ("build", "match"),
    [
        (lambda: PlateMaterial(E1=-1.0, E2=1e9, G12=1e9, nu12=0.3, density=1.0), r"material.E1: must be > 0"),
        (lambda: PlateMaterial.isotropic(70e9, 0.6, 2700.0), "material.nu: must be in"),
        (lambda: PlateMaterial(E1=1e9, E2=1e10, G12=1e9, nu12=0.4, density=1.0), "material.nu12"),
        (lambda: PlateStructure(material=PlateMaterial.isotropic(70e9, 0.3, 2700.0), thickness=0.0),
         "structure.thickness: must be > 0"),
        (lambda: PlateStructure(material=PlateMaterial.isotropic(70e9, 0.3, 2700.0), thickness_form="wedge"),
         "structure.thickness_form"),
        (lambda: PlateStructure(material=PlateMaterial.isotropic(70e9, 0.3, 2700.0), fe_n_chord=1),
         "structure.fe_n_chord"),
        (lambda: StiffeningBeam(PlateMaterial.isotropic(70e9, 0.3, 2700.0), 1.2, 0.5, 1e-3),
         "structure.beam.root_position"),
        (lambda: LumpedMass(mass=-1.0, span_fraction=0.5), "structure.lumped_mass.mass"),
        (lambda: BeamStructure(1.0, 1.0, 1.0, 1.0, 0.3, 1.3), "structure.cg_chord_fraction"),
        (lambda: DesignVariable("x", 1.0, 0.5), "design_variables.x.upper: must be > lower"),
    ],
)
def test_bad_structure_values_raise_naming_the_field(build, match):
    with pytest.raises(ValueError, match=match):
        build()


def test_design_variable_target_must_exist():
    w = template("cropped-delta")
    dv = DesignVariable("y", 0.0, 1.0, target="beam.depth")
    with pytest.raises(ValueError, match=r"design_variables.y.target: 'beam.depth' is not a field"):
        dataclasses.replace(w, design_variables=(dv,))


def test_user_wing_with_orthotropic_airfoil_plate():
    pf = Planform(0.5587, 0.3682, 0.762, math.radians(46.7), 8, 10)
    mat = PlateMaterial(E1=3.151e9, E2=0.4162e9, G12=0.4392e9, nu12=0.31, density=382.0)
    s = PlateStructure(material=mat, thickness_form="naca4", thickness_to_chord=0.04)
    dv = DesignVariable("t", 0.5, 1.5, "", "thickness scale", "thickness_ratio")
    w = WingDefinition("agard-like", pf, s, (dv,))
    assert not w.has_baseline
    with pytest.raises(ValueError, match="has no baseline"):
        w.structure_for(None)
    assert w.structure_for({"t": 1.2}).thickness_ratio == 1.2
    assert WingDefinition.from_dict(json.loads(json.dumps(w.to_dict()))) == w


def test_isotropic_q_is_orientation_invariant_and_orthotropic_rotates():
    iso = PlateMaterial.isotropic(70e9, 0.33, 2700.0)
    iso_rot = dataclasses.replace(iso, orientation=0.7)
    np.testing.assert_allclose(iso_rot.plane_stress_q(), iso.plane_stress_q(), rtol=1e-12, atol=1e-3)
    orth = PlateMaterial(E1=3e9, E2=0.5e9, G12=0.4e9, nu12=0.3, density=400.0)
    q = orth.plane_stress_q()  # axis 1 along +y (span): Q22 (yy) is the stiff one
    assert q[1, 1] > 5 * q[0, 0]
    q90 = dataclasses.replace(orth, orientation=math.pi / 2).plane_stress_q()
    assert math.isclose(q90[0, 0], q[1, 1], rel_tol=1e-12) and abs(q90[0, 2]) < 1e-6 * q90[0, 0]
