"""Rational function approximation (Roger) and the coupling of continuous ROMs with D1/D2 terms.

References: closed-form roots of one-mode systems with pure aerodynamic damping or apparent mass, and the p-k
solution on the same RFA (p-k is exact at the flutter point, so the two must agree to the crossing tolerance).
"""

import math

import numpy as np
import pytest

from romams_core.errors import InputError
from romams_core.flutter import flutter_analysis
from romams_core.mesh import standard_mesh
from romams_core.pk import pk_flutter
from romams_core.pk_reference import uvlm_table
from romams_core.rfa import RogerRfa, fit_rfa
from romams_core.statespace import ContinuousSS, to_modal
from romams_core.structure.modal import modal_analysis
from romams_core.wing import template

K = np.array([0.0, 0.02, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.65, 0.8, 1.0, 1.25, 1.5, 1.75, 2.0])


def _synthetic(m: int = 3, lags=(0.3, 1.7), pairs=()) -> RogerRfa:
    rng = np.random.default_rng(4)
    mats = rng.normal(size=(3 + len(lags), m, m))
    return RogerRfa(lags=np.array(lags), a0=mats[0], a1=mats[1], a2=0.1 * mats[2], a_lag=mats[3:],
                    pairs=np.array(pairs, complex), a_pair=rng.normal(size=(len(pairs), 2, m, m)))


def test_fit_recovers_complex_lag_pairs():
    """A model with one real lag and one complex pair (a wavy GAF) is found by the automatic choice (3 units)."""
    true = _synthetic(lags=(0.5,), pairs=(1.0 + 2.0j,))
    fit = fit_rfa(K, true(K), tol=1e-5)
    assert fit.rfa.n_lags == 3 and fit.rfa.pairs.size == 1
    assert fit.max_error < 1e-5
    np.testing.assert_allclose(fit.rfa.pairs[0], 1.0 + 2.0j, rtol=1e-3)


def test_fit_recovers_an_exact_roger_model():
    true = _synthetic()
    fit = fit_rfa(K, true(K), n_lags=2)
    assert fit.max_error < 1e-5  # the lag optimizer stops at its own tolerance
    np.testing.assert_allclose(np.sort(fit.rfa.lags), [0.3, 1.7], rtol=1e-4)
    kk = np.linspace(0.0, 3.0, 31)  # also outside the table
    np.testing.assert_allclose(fit.rfa(kk), true(kk), atol=1e-5 * np.max(np.abs(true(kk))))


def test_automatic_lag_choice_stops_at_the_tolerance():
    true = _synthetic()
    fit = fit_rfa(K, true(K), tol=1e-6)
    assert fit.rfa.n_lags == 2  # 0 and 1 lag cannot reach 1e-6 on a 2-lag model, 2 can
    assert fit.errors_by_lags[0] > 1e-3 and fit.errors_by_lags[1] > 1e-6 >= fit.errors_by_lags[2]


def test_realization_matches_the_rfa_and_modal_transform():
    rfa = _synthetic(pairs=(0.8 + 1.5j, 2.0 + 0.5j))
    ss = rfa.state_space()
    kk = np.linspace(0.0, 2.0, 9)
    np.testing.assert_allclose(ss.freqresp(kk), rfa(kk), rtol=1e-12, atol=1e-12)
    assert ss.is_stable()
    gamma = np.random.default_rng(1).normal(size=(3, 2))
    modal = to_modal(ss, gamma)
    assert isinstance(modal, ContinuousSS)
    np.testing.assert_allclose(modal.freqresp(kk), np.einsum("ai,nab,bj->nij", gamma, rfa(kk), gamma),
                               rtol=1e-12, atol=1e-12)


def _one_mode(d1: float = 0.0, d2: float = 0.0) -> ContinuousSS:
    z = np.zeros((0, 0))
    return ContinuousSS(A=z, B=np.zeros((0, 1)), C=np.zeros((1, 0)), D=np.zeros((1, 1)),
                        D1=np.array([[d1]]), D2=np.array([[d2]]))


def test_apparent_mass_lowers_the_frequency_as_in_closed_form():
    """T(s) = s^2 (1 - rho c^2 d2 / 2) + omega^2: s = i omega / sqrt(1 - rho c^2 d2 / 2) at any speed."""
    omega, c, rho, d2 = 50.0, 0.5, 1.2, -0.8  # negative d2: added (apparent) mass
    r = flutter_analysis(np.array([omega]), _one_mode(d2=d2), c, 0.0, sweep="constant-density", rho_ref=rho,
                         a_ref=340.0, v_max=100.0)
    expected = omega / math.sqrt(1.0 - 0.5 * rho * c * c * d2)
    assert not r.flutter_found
    np.testing.assert_allclose(r.omega[-1], expected, rtol=1e-9)
    np.testing.assert_allclose(r.g[-1], 0.0, atol=1e-9)


def test_aerodynamic_damping_term_as_in_closed_form():
    """T(s) = s^2 - (q c / V) d1 s + omega^2: Re(s) = q c d1 / (2 V) = rho V c d1 / 4."""
    omega, c, rho, d1, v_max = 80.0, 0.4, 1.0, -2.0, 60.0
    r = flutter_analysis(np.array([omega]), _one_mode(d1=d1), c, 0.0, sweep="constant-density", rho_ref=rho,
                         a_ref=340.0, v_max=v_max)
    v = r.v[-1]
    sigma = rho * v * c * d1 / 4.0
    s = complex(sigma, math.sqrt(omega**2 - sigma**2))
    np.testing.assert_allclose(r.omega[-1], s.imag, rtol=1e-9)
    np.testing.assert_allclose(r.g[-1], 2.0 * s.real / abs(s), rtol=1e-8)


@pytest.fixture(scope="module")
def cropped_delta_table():
    wing = template("cropped-delta")
    mesh = standard_mesh(wing.planform)
    modal = modal_analysis(wing, None, 4, mesh)
    return mesh, modal, uvlm_table(mesh, modal.shapes, 0.87, k_max=2.0, n_k=15)


def test_continuous_rom_flutter_equals_pk_on_the_same_rfa(cropped_delta_table):
    """The flutter search on the RFA realization (D1, D2 coupled explicitly) and p-k with the RFA evaluated at
    each root's k find the same flutter point (p-k is exact at g = 0): within 2e-4 in q_f and omega_f."""
    mesh, modal, table = cropped_delta_table
    fit = fit_rfa(table.k, table.h)
    assert fit.max_error < 0.005
    r = flutter_analysis(modal.omega, fit.rfa.state_space(), mesh.c_ref, 0.87, sweep="constant-speed")
    pk = pk_flutter(modal.omega, fit.rfa, mesh.c_ref, 0.87, sweep="constant-speed")
    assert r.flutter_found and pk.flutter_found and r.flutter_mode == pk.flutter_mode
    assert r.q_flutter_pa == pytest.approx(pk.q_flutter_pa, rel=2e-4)
    assert r.omega_flutter_rad_s == pytest.approx(pk.omega_flutter_rad_s, rel=2e-4)
    assert r.dt_star == 0.0  # a continuous model
    # the fit itself moves the flutter point little against p-k on the table (cubic spline in k)
    pk_table = pk_flutter(modal.omega, table, mesh.c_ref, 0.87, sweep="constant-speed")
    assert r.q_flutter_pa == pytest.approx(pk_table.q_flutter_pa, rel=0.01)


def test_bad_input_names_the_field():
    with pytest.raises(InputError) as e:
        fit_rfa(np.array([0.0, 0.1]), np.zeros((2, 1, 1), complex))
    assert e.value.field == "k_values"
    with pytest.raises(InputError) as e:
        fit_rfa(K, np.full((K.size, 2, 2), np.nan, complex))
    assert e.value.field == "gaf"
    with pytest.raises(InputError) as e:
        flutter_analysis(np.array([10.0]), _one_mode(d1=-1.0), 0.5, 0.5, coupling="zoh")
    assert e.value.field == "coupling"
    unstable = ContinuousSS(A=np.array([[0.1]]), B=np.ones((1, 1)), C=np.ones((1, 1)), D=np.zeros((1, 1)))
    with pytest.raises(InputError) as e:
        flutter_analysis(np.array([10.0]), unstable, 0.5, 0.5)
    assert e.value.field == "aero.A"


def test_structural_content_of_the_fast_path_equals_the_full_eigenvectors_with_d1_d2(cropped_delta_table):
    """The D1, D2 terms act on the structural states: the fast path's participation (null vectors of T(s)) must
    equal the participation of [xi; xi'] in the full first-order eigenvectors (to 1e-6)."""
    from romams_core.flutter.eigen import _full_vectors, _tustin_matrices, struct_vectors
    from romams_core.flutter.model import make_model

    mesh, modal, table = cropped_delta_table
    fit = fit_rfa(table.k, table.h)
    m = make_model(modal.omega, np.zeros(4), mesh.c_ref, fit.rfa.state_space(), "tustin")
    v, q = np.array([150.0, 260.0]), np.array([3000.0, 9000.0])
    lam, vec = np.linalg.eig(_tustin_matrices(m, v, q))
    _, content_full = _full_vectors(vec, m.omega)
    fast = struct_vectors(m, lam.astype(complex), v, q)
    assert fast is not None
    np.testing.assert_allclose(fast[1], content_full, atol=1e-6)


@pytest.mark.parametrize(("kw", "field"), [
    ({"k_values": []}, "k_values"),
    ({"k_values": [0.0, 0.1, 0.2]}, "k_values"),  # fewer than 4
    ({"n_lags": 13}, "n_lags"),
    ({"max_lags": True}, "max_lags"),
    ({"fit_tol": 0.0}, "fit_tol"),
    ({"reduce_order": "some"}, "reduce_order"),
    ({"lattice_refine": 0}, "lattice_refine"),
    ({"lattice_refine": True}, "lattice_refine"),
    ({"lattice_refine": 1}, "lattice_refine"),  # a solver without a lattice
])
def test_training_settings_are_checked_before_the_solver_runs(kw, field):
    """train_rfa_rom validates its settings (check_rfa_settings, also used by the API) before the solver's run."""
    from romams_core.training_rfa import train_rfa_rom

    class NeverCalled:
        name = "never"

        def gaf(self, *args, **kwargs):
            raise AssertionError("the solver ran before the settings were checked")

    wing = template("cropped-delta")
    mesh = standard_mesh(wing.planform)
    with pytest.raises(InputError) as e:
        train_rfa_rom(mesh, np.zeros((mesh.n_nodes, 2)), 0.5, NeverCalled(), **kw)
    assert e.value.field == field


def test_lattice_refine_trains_on_that_lattice():
    """``lattice_refine`` gives the GAF table of ``DlmSolver(refine=n)``, whatever the passed solver's refinement."""
    from romams_core.aero.dlm import DlmSolver
    from romams_core.training_rfa import train_rfa_rom

    wing = template("cropped-delta")
    mesh = standard_mesh(wing.planform)
    shapes = modal_analysis(wing, None, 2, mesh).shapes
    k = np.array([0.0, 0.2, 0.5, 1.0])
    rom = train_rfa_rom(mesh, shapes, 0.5, DlmSolver(), k_values=k, lattice_refine=1)
    ref = DlmSolver(refine=1).gaf(mesh, shapes, 0.5, k)
    np.testing.assert_allclose(rom.gaf, ref, rtol=1e-12, atol=1e-14 * np.abs(ref).max())
    assert "refined 1x" in rom.solver_description
