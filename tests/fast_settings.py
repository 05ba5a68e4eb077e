"""Training settings of the tests that exercise the service, the tracker or the ROM-AMS transformation, not the
accuracy of the doublet lattice itself (those tests train with the product's defaults)."""

#: DLM ROM on one box per standard-mesh panel: about 7x faster training than the default 2x2 lattice
#: (``romams_core.training_rfa.train_rfa_rom``, ``lattice_refine``)
DLM_FAST = {"lattice_refine": 1}
#: the smallest useful RFA ROM on the default lattice: four reduced frequencies, one lag (a smoke ROM for plumbing;
#: about 1 s of training with the compiled DLM kernel)
RFA_FAST = {"k_values": [0.0, 0.1, 0.3, 0.6], "n_lags": 1}
#: a training that lasts (about 9 s on an idle 2-core machine: 12 reduced frequencies on the 3x3 lattice), for the
#: fault tests whose training must still run while a server is down
RFA_LONG = {"k_values": [0.0, 0.02, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.6, 0.8, 1.0], "n_lags": 1,
            "lattice_refine": 3}


def baseline_dlm_rom(mach: float):
    """(wing, mesh, modal, rom): the cropped delta's baseline 4 modes and their DLM RFA ROM at ``mach`` on one box
    per panel (the reference of the GAF-table import tests)."""
    from romams_core.aero.dlm import DlmSolver
    from romams_core.mesh import standard_mesh
    from romams_core.structure.modal import modal_analysis
    from romams_core.training_rfa import train_rfa_rom
    from romams_core.wing import template

    wing = template("cropped-delta")
    mesh = standard_mesh(wing.planform)
    modal = modal_analysis(wing, None, 4, mesh)
    return wing, mesh, modal, train_rfa_rom(mesh, modal.shapes, mach, DlmSolver(refine=1))
