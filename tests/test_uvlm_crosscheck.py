"""The UVLM ROM's aerodynamic damping is checked against the doublet lattice: the cropped delta's chordwise-bending
mode (mode 4, 213 Hz) is flagged, the others are not (docs/aerodynamics.md, section 11)."""

import numpy as np

from romams.services.training import rom_identity, train
from romams_core.aero.crosscheck import damping_disagreements
from romams_core.mesh import standard_mesh
from romams_core.structure.modal import modal_analysis
from romams_core.wing import template


def test_disagreement_rule():
    k = np.array([0.5])
    ref = np.array([[[10 - 1.0j, 0], [0, 10 - 0.1j]]])  # mode 2's reference damping is below 2 % of |H|: ignored
    rom = np.array([[[10 - 0.2j, 0], [0, 10 + 0.5j]]])
    assert damping_disagreements(rom, ref, k) == [(0, 0.5, 10 - 0.2j, 10 - 1.0j)]
    assert damping_disagreements(np.array([[[10 - 0.3j, 0], [0, 10 + 0.5j]]]), ref, k) == []  # 0.3 > 1/4 of 1


def test_uvlm_rom_of_the_chordwise_bending_mode_is_flagged():
    wing = template("cropped-delta")
    mesh = standard_mesh(wing.planform)
    modal = modal_analysis(wing, None, 4, mesh)
    rom = train(mesh, modal.shapes, 0.01, rom_identity("uvlm"))
    flagged = [w for w in rom.warnings if "damps it by less than" in w]
    assert len(flagged) == 1 and flagged[0].startswith("shape 4:")
