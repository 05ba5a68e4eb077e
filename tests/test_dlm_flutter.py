"""Flutter with the doublet-lattice solver: RFA ROMs (ROM-AMS, ROM-PMS) against the full-order DLM p-k, and the
Goland wing against its published 3-D value.

References: Goland wing at rho = 1.02 kg/m^3, M ~ 0: 166 m/s (UVLM + beam, SHARPy, validation.md), asked within
3 %; ROM-AMS vs ROM-PMS vs full-order p-k (the DLM's own GAF on the structure's modes, exact at the flutter k):
within 1 % in flutter speed (the issue's accuracy target; the benchmark runs 20 designs x 5 Machs).
"""

import numpy as np
import pytest
from fast_settings import DLM_FAST

from romams.pipeline import own_mode_basis
from romams_core.aero.dlm import DlmSolver
from romams_core.basis import build_basis_for_wing, project, random_designs
from romams_core.evaluate import evaluate_structure
from romams_core.flutter import flutter_analysis
from romams_core.mesh import standard_mesh
from romams_core.pk_reference import fom_flutter
from romams_core.structure.modal import modal_analysis
from romams_core.training_rfa import train_rfa_rom
from romams_core.wing import template

GOLAND_K = (0.0, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.7, 1.0)


def test_goland_flutter_speed_with_dlm_within_3_percent():
    wing = template("goland")
    mesh = standard_mesh(wing.planform)
    modal = modal_analysis(wing, None, 4, mesh)
    basis = own_mode_basis(wing, 4)
    rom = train_rfa_rom(mesh, basis.shapes, 0.0, DlmSolver(), k_values=GOLAND_K)
    assert rom.max_fit_error < 0.01
    gamma = project(basis.shapes, modal.shapes).gamma
    from romams_core.statespace import to_modal

    r = flutter_analysis(modal.omega, to_modal(rom.ss, gamma), rom.c_ref, 0.0, sweep="constant-density",
                         rho_ref=1.02, a_ref=340.3, v_max=300.0)
    assert r.flutter_found and not r.sdoff
    assert r.v_flutter_m_s == pytest.approx(166.0, rel=0.03)
    assert r.omega_flutter_rad_s == pytest.approx(69.8, rel=0.06)  # bending-torsion coalescence
    assert r.flutter_mode == 2


@pytest.mark.slow
def test_cropped_delta_rom_ams_vs_rom_pms_vs_full_order_dlm_pk():
    """3 random designs at M 0.87 (constant speed at 10 km): every pair within 1 % in EAS (i.e. q_f)."""
    wing = template("cropped-delta")
    mesh = standard_mesh(wing.planform)
    basis = build_basis_for_wing(wing, samples=12, modes=4, mac_threshold=0.9999, max_basis=8)
    solver = DlmSolver(refine=1)  # the three methods on one lattice: the coarsest (the lattice is not tested here)
    mach = 0.87
    rom = train_rfa_rom(mesh, basis.shapes, mach, solver)
    assert rom.max_fit_error < 0.01
    for x in random_designs(wing, 3, seed=11):
        modal = modal_analysis(wing, x, 4, mesh)
        ams = evaluate_structure(modal, basis.shapes, {mach: rom}, zeta=wing.modal_damping,
                                 mac_threshold=0.99).flutter[0]
        own = train_rfa_rom(mesh, modal.shapes, mach, solver)
        pms = flutter_analysis(modal.omega, own.ss, own.c_ref, mach, zeta=wing.modal_damping)
        fom, _ = fom_flutter(mesh, modal.omega, modal.shapes, mach, zeta=wing.modal_damping, solver=solver, dk=0.1)
        assert ams.flutter_found and pms.flutter_found and fom.flutter_found
        assert ams.flutter_mode == pms.flutter_mode == fom.flutter_mode
        v = np.sqrt([ams.q_flutter_pa, pms.q_flutter_pa, fom.q_flutter_pa])  # EAS ratio = sqrt(q ratio)
        assert v[0] == pytest.approx(v[1], rel=0.01)
        assert v[0] == pytest.approx(v[2], rel=0.01)
        assert v[1] == pytest.approx(v[2], rel=0.01)


#: AGARD 445.6 weakened, experiment (Yates, agard445 reference): Mach -> (density kg/m^3, V_f m/s, omega_f rad/s)
AGARD = {0.499: (0.4278, 172.46, 128.1), 0.678: (0.2082, 231.37, 113.0), 0.901: (0.0995, 296.69, 101.1)}


@pytest.mark.slow
def test_agard_445_6_flutter_speed_within_6_percent_and_frequency_falling_with_mach():
    """Own 4 modes, DLM RFA ROM, matched Mach as in the tunnel (V = V_exp, the density swept; the equivalent speed
    sqrt(2 q_f / rho_exp); measured -1.2, +0.9, -0.7 %, ``benchmarks.validate_tsd``'s DLM rows), and a
    constant-density sweep at the experiment's density (measured -1.08, +0.96, -0.65 %; +0.89 % at M 0.678
    with the gated artifact). That sweep starts at
    V = 0, far above the RFA's fitted k <= 2, where on one machine's round-off the fit gave mode 2 negative damping
    below 15 m/s and, before the band gate, a "flutter" at 0.0007 m/s (docs/flutter.md 9.10)."""
    wing = template("agard-445.6")
    mesh = standard_mesh(wing.planform)
    modal = modal_analysis(wing, None, 4, mesh)
    omegas = []
    for mach, (rho, v_exp, _) in AGARD.items():
        rom = train_rfa_rom(mesh, modal.shapes, mach, DlmSolver())
        r = flutter_analysis(modal.omega, rom.ss, rom.c_ref, mach, sweep="constant-speed", rho_ref=rho,
                             a_ref=v_exp / mach)
        assert r.flutter_found and not r.sdoff
        assert np.sqrt(2.0 * r.q_flutter_pa / rho) == pytest.approx(v_exp, rel=0.06)
        omegas.append(r.omega_flutter_rad_s)
        rd = flutter_analysis(modal.omega, rom.ss, rom.c_ref, mach, sweep="constant-density", rho_ref=rho,
                              a_ref=v_exp / mach, v_max=2.0 * v_exp, k_band=rom.k_max)
        assert rd.flutter_found and not rd.sdoff and not rd.outside_band and rd.flutter_mode == r.flutter_mode
        assert rd.v_flutter_m_s == pytest.approx(v_exp, rel=0.06)
    assert omegas[0] > omegas[1] > omegas[2]  # experiment: 128.1, 113.0, 101.1 rad/s
    assert omegas[2] == pytest.approx(101.1, rel=0.1)


@pytest.mark.slow
def test_rfa_rom_flutter_point_does_not_depend_on_the_sweep_points():
    """As for the ARX ROMs (tests/test_flutter_sweep_independence.py): 12 and 60 coarse points give the same mode
    and q_f within 0.1 %, no lag root taken (benchmark run: 20 designs x 5 Machs x 2 sweeps x 12/24/60/200
    points, largest deviation 7.1e-5)."""
    from romams_core.statespace import to_modal

    wing = template("cropped-delta")
    mesh = standard_mesh(wing.planform)
    basis = build_basis_for_wing(wing, samples=12, modes=4, mac_threshold=0.9999, max_basis=8)
    roms = {m: train_rfa_rom(mesh, basis.shapes, m, DlmSolver(), **DLM_FAST) for m in (0.87, 0.95)}
    for x in [None, *random_designs(wing, 2, seed=3)]:
        modal = modal_analysis(wing, x, 4, mesh)
        gamma = project(basis.shapes, modal.shapes).gamma
        for mach, rom in roms.items():
            for sweep in ("constant-speed", "constant-density"):
                a, b = (flutter_analysis(modal.omega, to_modal(rom.ss, gamma), mesh.c_ref, mach, sweep=sweep,
                                         n_points=n) for n in (12, 60))
                assert a.flutter_found and b.flutter_found and a.flutter_mode == b.flutter_mode
                assert not (a.lag_root_flagged or b.lag_root_flagged)
                assert a.q_flutter_pa == pytest.approx(b.q_flutter_pa, rel=1e-3)
