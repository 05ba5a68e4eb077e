"""Flat shell + eccentric stiffener: verification numbers and mesh convergence (docs/structure.md, section 3b).

Prints JSON with:

* ``strip``: a cantilever plate strip with an eccentric stiffener along its centre line against the
  Euler-Bernoulli frequency of the composite section (parallel-axis theorem about the composite
  neutral axis), on 10 .. 80 elements along the span; the same strip with the beam on the mid-plane;
* ``inplane_strip``: in-plane bending of a slender strip (Allman membrane only) against beam theory;
* ``bare_plate``: the cropped delta's bare plate with and without the membrane DOFs, and its first
  in-plane (membrane) frequencies;
* ``cropped_delta``: mid-plane vs eccentric beam at the paper's optimum and at a mid-range design,
  the membrane DOFs' share of each mode's kinetic energy, and the eccentric case's mesh convergence.

The tests (``tests/test_structure_shell.py``) import the helpers below.

Usage: python -m benchmarks.shell_stiffener_study
"""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
from scipy.sparse.linalg import eigsh

from romams_core.mesh import Planform
from romams_core.structure.modal import FEModel, modal_analysis, plate_model, solve_modes
from romams_core.wing import PlateMaterial, PlateStructure, StiffeningBeam, WingDefinition, cropped_delta

E, RHO, T = 70.0e9, 2700.0, 1.5e-3  # strip: aluminium, nu = 0 (beam theory holds exactly across the width)
STRIP_CHORD, STRIP_SPAN, BEAM_H, BEAM_B = 0.02, 0.5, 2.0e-3, 2.0e-3
PAPER_OPTIMUM = {"x1": 0.1535, "x2": 0.6135, "x3": 0.8247, "x4": 0.0203, "x5": 1.966, "x6": 0.8787, "x7": 0.5972}
MID_DESIGN = {"x1": 0.25, "x2": 0.6, "x3": 0.8, "x4": 0.05, "x5": 1.5, "x6": 1.2, "x7": 0.8}
BETA1 = 1.8751  # first cantilever eigenvalue beta L


def strip_model(n_span: int, placement: str, membrane: bool | None = None, n_chord: int = 2) -> FEModel:
    """FE model of the stiffened cantilever strip (beam along the centre line, root clamped)."""
    mat = PlateMaterial.isotropic(E, 0.0, RHO)
    beam = StiffeningBeam(mat, 0.5, 0.5, BEAM_H, BEAM_B / BEAM_H, placement)
    s = PlateStructure(material=mat, thickness=T, beam=beam, fe_n_chord=n_chord, fe_n_span=n_span)
    return plate_model(Planform(STRIP_CHORD, STRIP_CHORD, STRIP_SPAN, 0.0, 2, 4), s, membrane=membrane)


def strip_beam_theory(placement: str) -> float:
    """First bending frequency (rad/s) of the strip: 1.8751^2 sqrt(EI / (m L^4)), EI about the neutral axis."""
    a_p, a_b = STRIP_CHORD * T, BEAM_H * BEAM_B
    i_p, i_b = STRIP_CHORD * T**3 / 12.0, BEAM_B * BEAM_H**3 / 12.0
    e = 0.5 * (T + BEAM_H) if placement == "eccentric" else 0.0
    z_na = a_b * e / (a_p + a_b)  # composite neutral axis above the plate mid-plane (beam side)
    ei = E * (i_p + a_p * z_na**2 + i_b + a_b * (e - z_na) ** 2)
    return BETA1**2 * math.sqrt(ei / (RHO * (a_p + a_b) * STRIP_SPAN**4))


def membrane_block_omegas(model: FEModel, k: int) -> np.ndarray:
    """Lowest k in-plane frequencies (rad/s) of a shell model's membrane DOFs alone (bending DOFs held)."""
    f = model.free
    memb = f[(f % model.dofs_per_node) >= 3]
    kk, mm = model.K[memb][:, memb].tocsc(), model.M[memb][:, memb].tocsc()
    v0 = np.random.default_rng(0).standard_normal(memb.size)
    lam = eigsh(kk, k=k, M=mm, sigma=0.0, which="LM", v0=v0, return_eigenvectors=False)
    return np.sqrt(np.sort(lam))


def inplane_strip_error(n_chord: int, n_span: int, chord: float = 0.05, span: float = 1.0) -> float:
    """Relative error of the first in-plane bending frequency of a slender cantilever strip against beam theory."""
    s = PlateStructure(material=PlateMaterial.isotropic(E, 0.3, RHO), thickness=1.0e-3, fe_n_chord=n_chord,
                       fe_n_span=n_span)
    model = plate_model(Planform(chord, chord, span, 0.0, 2, 4), s, membrane=True)
    exact = BETA1**2 * math.sqrt(E * chord**2 / 12.0 / (RHO * span**4))  # EI / m = E b^2 / 12 (free sides)
    return float(membrane_block_omegas(model, 1)[0] / exact - 1.0)


def membrane_energy_share(model: FEModel, phi: np.ndarray) -> np.ndarray:
    """Share of each mass-normalized mode's kinetic energy in the membrane DOFs u, v, theta_z [k]."""
    memb = (np.arange(model.K.shape[0]) % model.dofs_per_node) >= 3
    pm = np.where(memb[:, None], phi, 0.0)
    return np.einsum("ik,ik->k", pm, model.M @ pm)


def with_mesh(wing: WingDefinition, n_chord: int, n_span: int) -> WingDefinition:
    """The wing with its plate FE mesh set to n_chord x n_span cells."""
    return dataclasses.replace(wing, structure=dataclasses.replace(wing.structure, fe_n_chord=n_chord,
                                                                   fe_n_span=n_span))


def _strip() -> dict:
    """Eccentric and mid-plane strip against the composite-section frequency."""
    ecc = strip_beam_theory("eccentric")
    rows = []
    for ns in (10, 20, 40, 80):
        om = solve_modes(strip_model(ns, "eccentric"), 1)[0][0]
        rows.append({"n_span": ns, "omega": float(om), "error_pct": 100 * float(om / ecc - 1)})
    mid = strip_beam_theory("mid-plane")
    om_mid = solve_modes(strip_model(40, "mid-plane"), 1)[0][0]
    return {"beam_theory_eccentric": ecc, "eccentric": rows, "beam_theory_mid_plane": mid,
            "mid_plane_40": float(om_mid), "mid_plane_error_pct": 100 * float(om_mid / mid - 1)}


def _cropped_delta() -> dict:
    """Mid-plane vs eccentric designs, membrane energy shares, and the eccentric mesh convergence."""
    mid, ecc = cropped_delta(), cropped_delta("eccentric")
    out: dict = {}
    for name, x in (("paper_optimum", PAPER_OPTIMUM), ("mid_design", MID_DESIGN)):
        rm, re_ = modal_analysis(mid, x, 6), modal_analysis(ecc, x, 6)
        model = plate_model(ecc.planform, ecc.structure_for(x))
        om, phi = solve_modes(model, 8)
        out[name] = {"mid_plane_hz": rm.frequencies_hz.tolist(), "eccentric_hz": re_.frequencies_hz.tolist(),
                     "mass_kg": re_.mass_kg, "membrane_share_8": membrane_energy_share(model, phi).tolist()}
    conv = []
    for nc, ns in ((6, 8), (12, 16), (24, 32), (48, 64)):
        r = modal_analysis(with_mesh(ecc, nc, ns), PAPER_OPTIMUM, 4)
        conv.append({"cells": f"{nc} x {ns}", "hz": r.frequencies_hz.tolist()})
    out["convergence_paper_optimum"] = conv
    return out


def main() -> None:
    """Print the study as JSON."""
    wing = cropped_delta()
    m3, m6 = plate_model(wing.planform, wing.baseline), plate_model(wing.planform, wing.baseline, membrane=True)
    bare = {"bending_only_hz": (solve_modes(m3, 4)[0] / (2 * np.pi)).tolist(),
            "shell_hz": (solve_modes(m6, 4)[0] / (2 * np.pi)).tolist(),
            "first_inplane_hz": (membrane_block_omegas(m6, 3) / (2 * np.pi)).tolist()}
    inplane = [{"cells": f"{nc} x {ns}", "error_pct": 100 * inplane_strip_error(nc, ns)}
               for nc, ns in ((2, 20), (4, 40), (8, 80), (8, 160))]
    print(json.dumps({"strip": _strip(), "inplane_strip": inplane, "bare_plate": bare,
                      "cropped_delta": _cropped_delta()}, indent=1))


if __name__ == "__main__":
    main()
