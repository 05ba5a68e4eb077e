"""Excitation signals and ROM training, on synthetic shapes and on the cropped delta wing (ROM-AMS vs direct)."""

import math

import numpy as np
import pytest

from romams_core.aero.uvlm import UvlmSolver, uvlm_warnings
from romams_core.arx import nrmse
from romams_core.basis import build_basis_for_wing, project, random_designs
from romams_core.mesh import Planform, standard_mesh
from romams_core.signals import cross_correlation, excitation_signals, multisine
from romams_core.statespace import to_modal
from romams_core.structure.modal import modal_analysis
from romams_core.training import TrainingError, train_rom
from romams_core.wing import template


def _synthetic(nc: int = 6, ns: int = 8):
    pf = Planform(root_chord=0.4, tip_chord=0.08, semispan=0.28, sweep_le=math.radians(43), n_chord=nc, n_span=ns)
    mesh = standard_mesh(pf)
    xi, eta = pf.to_xi_eta(mesh.x, mesh.y)
    shapes = np.column_stack([eta**2, eta**2 * (xi - 0.4), np.sin(math.pi * eta) * xi**2])
    return mesh, shapes


def test_signals_are_band_limited_uncorrelated_tapered_and_scaled():
    mesh, shapes = _synthetic()
    dt, k_max = 1.0 / 6, 1.5
    exc = excitation_signals(shapes, mesh.c_ref, 1500, dt, k_max=k_max, seed=4)
    for sig in (exc.train, exc.validation):
        corr = cross_correlation(sig)
        assert np.abs(corr - np.eye(3)).max() < 1e-10  # exactly orthogonal columns
        spec = np.abs(np.fft.rfft(sig, axis=0)) ** 2
        omega = 2 * math.pi * np.fft.rfftfreq(sig.shape[0], d=dt)
        out_of_band = spec[omega > 2 * k_max * 1.3].sum() / spec.sum()
        assert out_of_band < 1e-3
        assert np.abs(sig[0]).max() == 0.0 and np.abs(sig[-1]).max() < 1e-3 * np.abs(sig).max()  # tapered ends
    # the validation realization is drawn independently: its correlation with the training one is at the level
    # of chance (~ 1 / sqrt(number of frequency lines) = 0.09 here), not exactly zero
    assert np.abs(cross_correlation(np.hstack([exc.train, exc.validation]))[:3, 3:]).max() < 0.3
    assert not np.allclose(exc.train, exc.validation)
    # peak surface displacement is 1 % of the reference chord
    peak = max(np.abs(shapes @ exc.train.T).max(), np.abs(shapes @ exc.validation.T).max())
    assert peak == pytest.approx(0.01 * mesh.c_ref, rel=1e-12)
    again = excitation_signals(shapes, mesh.c_ref, 1500, dt, k_max=k_max, seed=4)
    np.testing.assert_array_equal(again.train, exc.train)
    with pytest.raises(ValueError, match="n_steps"):
        multisine(40, 3, dt, 0.01, np.random.default_rng(0))



def test_low_k_corner_raises_the_low_frequency_power_as_one_over_k():
    """Power share below k 0.1 of the signal against the share of the line amplitudes sqrt(1 + c / k), within 10 %
    (taper and orthonormalization leak a little between lines); corner 0 is the flat spectrum, bit for bit."""
    dt, k_max, n = 0.1, 1.5, 3584
    k = np.pi * np.fft.rfftfreq(n, d=dt)  # reduced frequency of each line (omega = 2 k per unit t*)
    line = (k > 0) & (k <= k_max)
    flat = multisine(n, 8, dt, k_max, np.random.default_rng(3))
    np.testing.assert_array_equal(flat, multisine(n, 8, dt, k_max, np.random.default_rng(3), low_k_corner=0.0))
    for corner in (0.0, 0.1, 0.3):
        x = multisine(n, 8, dt, k_max, np.random.default_rng(3), low_k_corner=corner)
        assert np.abs(cross_correlation(x) - np.eye(8)).max() < 1e-10
        power = (np.abs(np.fft.rfft(x, axis=0)) ** 2).sum(axis=1)
        share = power[k < 0.1].sum() / power.sum()
        weight = 1.0 + corner / k[line]
        assert share == pytest.approx(weight[k[line] < 0.1].sum() / weight.sum(), rel=0.1)
    assert share > 4 * (np.abs(np.fft.rfft(flat, axis=0)[k < 0.1]) ** 2).sum() / (np.abs(np.fft.rfft(flat, axis=0))
                                                                                 ** 2).sum()
    with pytest.raises(ValueError, match="low_k_corner"):
        multisine(n, 8, dt, k_max, np.random.default_rng(3), low_k_corner=2.0)
def test_train_rom_on_synthetic_shapes_and_tolerance_failure():
    mesh, shapes = _synthetic()
    solver = UvlmSolver(wake_chords=10.0)
    rom = train_rom(mesh, shapes, 0.6, solver, na=6, nb=6, n_steps=1200, reduce_order=None)
    assert rom.validation_nrmse.shape == (3,)
    assert rom.validation_nrmse.max() < 0.01
    assert rom.spectral_radius < 1.0 and rom.ss.n_states == 3 * (6 + 5)
    assert rom.dt_star == pytest.approx(1.0 / mesh.n_chord)
    assert rom.warnings == uvlm_warnings(0.6)  # only the solver's own: the phase error above M 0.5
    # a first-order ARX with a single input tap cannot reach a tiny tolerance: the error names the outputs
    with pytest.raises(TrainingError, match="output") as err:
        train_rom(mesh, shapes, 0.6, solver, na=1, nb=1, n_steps=600, nrmse_tol=1e-4)
    assert err.value.outputs
    with pytest.raises(ValueError, match="nrmse_tol"):
        train_rom(mesh, shapes, 0.6, solver, nrmse_tol=0.0)


def test_order_fallbacks_refit_the_same_records():
    """Orders 1/1 miss a 1 % tolerance; the fallback 6/6 meets it on the same run and is kept, with a note."""
    mesh, shapes = _synthetic()
    solver = UvlmSolver(wake_chords=10.0)
    rom = train_rom(mesh, shapes, 0.6, solver, na=1, nb=1, n_steps=1200, nrmse_tol=0.01, reduce_order=None,
                    order_fallbacks=((6, 6),))
    assert (rom.na, rom.nb) == (6, 6) and rom.validation_nrmse.max() < 0.01
    assert any("orders 1/1" in w and "refitted with 6/6" in w for w in rom.warnings)
    with pytest.raises(TrainingError, match=r"best of orders \[\(1, 1\), \(2, 1\)\]"):
        train_rom(mesh, shapes, 0.6, solver, na=1, nb=1, n_steps=600, nrmse_tol=1e-4, order_fallbacks=((2, 1),))


@pytest.fixture(scope="module")
def cropped_delta():
    wing = template("cropped-delta")
    mesh = standard_mesh(wing.planform)
    return wing, mesh


def test_cropped_delta_default_basis_validation_below_one_percent(cropped_delta):
    wing, mesh = cropped_delta
    basis = build_basis_for_wing(wing, samples=25, modes=4)
    rom = train_rom(mesh, basis.shapes, 0.87, UvlmSolver())
    assert rom.n_basis == basis.n_basis
    assert np.all(rom.validation_nrmse < 0.01)


def test_rom_ams_reproduces_direct_solver_for_real_modes(cropped_delta):
    # The GAC depend on the shape slopes, so the basis must fit the modes very closely: an 8-shape basis
    # (worst snapshot MAC >= 0.9999, as the paper's 8 PCA shapes) keeps ROM-AMS within 2 % of the direct run.
    wing, mesh = cropped_delta
    basis = build_basis_for_wing(wing, samples=25, modes=4, mac_threshold=0.9999)
    solver = UvlmSolver(refine=1)  # the transformation is solver-independent; the plain lattice keeps it fast
    rom = train_rom(mesh, basis.shapes, 0.87, solver, reduce_order="auto")
    assert rom.ss.n_states <= 64 < rom.n_states_full and np.all(rom.validation_nrmse < 0.002)
    for design in random_designs(wing, 3, seed=7):  # includes a design whose 4th mode fits with MAC 0.99998 only
        modal = modal_analysis(wing, design, n_modes=4)
        fit = project(basis.shapes, modal.shapes)
        assert fit.min_mac >= 0.99
        xi = excitation_signals(modal.shapes, mesh.c_ref, 1500, rom.dt_star, seed=11).train
        direct = solver.simulate(mesh, modal.shapes, xi, 0.87, rom.dt_star)
        ams = to_modal(rom.ss, fit.gamma).simulate(xi)
        assert np.all(nrmse(direct, ams) < 0.02)


def test_an_unreduced_arx_rom_keeps_its_minimal_realization():
    """An ARX ROM whose reduction was not accepted keeps the minimal realization of its ARX model: the
    shift-register states (defective poles at z = 0) go, the transfer matrix and the validation error stay, and the
    eigenvectors become well conditioned (the flutter search's fast path; docs/transonic.md 7.9)."""
    from romams_core.arx import ArxModel
    from romams_core.arx_identification import Records, minimal_arx_realization
    from romams_core.statespace import arx_to_ss

    a = np.zeros((4, 1, 1))
    a[0] = 0.8
    b = np.zeros((4, 1, 1))
    b[0], b[1] = 1.0, 0.5
    full = arx_to_ss(ArxModel(a=a, b=b, dt_star=0.1))  # a first-order system realized with 7 states
    assert full.n_states == 7 and np.linalg.cond(np.linalg.eig(full.A)[1]) > 1e12
    rng = np.random.default_rng(3)
    rec = Records(rng.standard_normal((300, 1)), rng.standard_normal((200, 1)))
    f = rec.simulate(full.simulate)
    red = minimal_arx_realization(full, rec, f, 300)
    assert red.n_states == 1 and red.is_stable()
    ks = np.array([0.0, 0.05, 0.3, 1.0])
    np.testing.assert_allclose(red.freqresp(ks), full.freqresp(ks), rtol=1e-8)
    assert np.max(nrmse(f[300:], rec.simulate(red.simulate)[300:])) < 1e-8
    noisy = f + 1e-3 * rng.standard_normal(f.shape)  # the records it validates on do not change the model kept
    assert minimal_arx_realization(full, rec, noisy, 300).n_states == 1


def test_a_mimo_arx_rom_keeps_its_minimal_realization_in_modal_form():
    """A stable 3-output ARX 4/4 model (21 states, 9 of them surplus input delays) goes to its na * p = 12-state
    minimal realization in real modal form: same transfer matrix to 1e-9 of the largest entry, eigenvector
    condition below DIAG_COND_MAX (the full realization's is above 1e12), the same poles."""
    from romams_core.arx import ArxModel
    from romams_core.arx_identification import Records, minimal_arx_realization
    from romams_core.realization import minimal_realization
    from romams_core.statespace import DIAG_COND_MAX, arx_to_ss, eigenvector_condition

    rng = np.random.default_rng(5)
    full = arx_to_ss(ArxModel(a=0.15 * rng.standard_normal((4, 3, 3)), b=rng.standard_normal((4, 3, 3)), dt_star=0.1))
    assert full.n_states == 21 and full.is_stable() and eigenvector_condition(full.A) > 1e12
    assert minimal_realization(full).n_states == 12
    rec = Records(rng.standard_normal((300, 3)), rng.standard_normal((200, 3)), continued=False)
    red = minimal_arx_realization(full, rec, rec.simulate(full.simulate), 300)
    assert red.n_states == 12 and eigenvector_condition(red.A) < min(DIAG_COND_MAX, 100.0)
    assert np.count_nonzero(np.abs(red.A) > 1e-12) <= 12 + 2 * 6  # block diagonal: 1x1 and 2x2 blocks
    ks = np.linspace(0.0, 1.0, 21)
    h_full = full.freqresp(ks)
    assert np.max(np.abs(red.freqresp(ks) - h_full)) < 1e-9 * np.max(np.abs(h_full))
    z_full = np.linalg.eigvals(full.A)
    z_red = np.linalg.eigvals(red.A)
    assert np.all(np.min(np.abs(z_red[:, None] - z_full[None, :]), axis=1) < 1e-6)
    lone = arx_to_ss(ArxModel(a=0.15 * rng.standard_normal((1, 3, 3)), b=rng.standard_normal((1, 3, 3)), dt_star=0.1))
    assert minimal_arx_realization(lone, rec, rec.simulate(lone.simulate), 300) is lone  # already minimal


def test_a_rom_stored_with_its_full_arx_realization_is_loaded_with_its_minimal_one(tmp_path):
    """A real (UVLM) ARX ROM kept unreduced holds the full ARX realization, 3 x (6 + 5) = 33 states with singular
    eigenvectors; ``with_minimal_realization`` (applied when ROMs are loaded from the store) gives its na p = 18
    states in modal form with the same transfer matrix (1e-6 of the largest entry) and the same validation output;
    a ROM already minimal, or reduced, comes back as it is."""
    from romams.persistence import open_store
    from romams.settings import Settings
    from romams_core.statespace import DIAG_COND_MAX, eigenvector_condition
    from romams_core.training import with_minimal_realization

    mesh, shapes = _synthetic()
    rom = train_rom(mesh, shapes, 0.6, UvlmSolver(wake_chords=10.0), na=6, nb=6, n_steps=1200, reduce_order=None)
    assert rom.ss.n_states == rom.n_states_full == 33 and eigenvector_condition(rom.ss.A) > DIAG_COND_MAX
    new = with_minimal_realization(rom)
    assert new.ss.n_states == 18 and eigenvector_condition(new.ss.A) < 1e3 and new.spectral_radius < 1.0
    ks = np.linspace(0.0, rom.k_max, 31)
    h = rom.ss.freqresp(ks)
    assert np.max(np.abs(new.ss.freqresp(ks) - h)) < 1e-6 * np.max(np.abs(h))
    assert with_minimal_realization(new) is new
    store = open_store(Settings(data_dir=tmp_path / "data"))
    wid = store.wings.ensure(template("cropped-delta"))
    bid = store.bases.save(wid, build_basis_for_wing(template("cropped-delta"), samples=4, modes=2), {"samples": 4})
    rid = store.roms.save(wid, bid, rom, {"solver": "uvlm", "na": 6, "nb": 6, "mach": 0.6})
    loaded = store.roms.load(rid)
    assert loaded.ss.n_states == 18 and np.allclose(loaded.ss.freqresp(ks), new.ss.freqresp(ks), rtol=0, atol=1e-12)


class _OutOfBandTone:
    """The UVLM plus, on each output, a tone at k 7 of a tenth of that output's RMS: response far outside the
    excitation band (k <= 1.5) that no linear model of the input gives, like the TSD's at M 0.96 on a fine grid."""

    name = "uvlm+tone"

    def __init__(self) -> None:
        self.uvlm = UvlmSolver(wake_chords=10.0)

    def simulate(self, mesh, shapes, signals, mach, dt_star, progress=None):  # noqa: ANN001, ANN201
        lin = self.uvlm.simulate(mesh, shapes, signals, mach, dt_star)
        t = dt_star * np.arange(lin.shape[0])
        rms = np.sqrt(np.mean(lin**2, axis=0))
        return lin + 0.1 * rms * np.sqrt(2.0) * np.cos(14.0 * t[:, None] + np.arange(lin.shape[1]))


def test_validation_band_counts_the_response_inside_it():
    """With the tone, the whole-record validation NRMSE is about 10 % and a 5 % tolerance fails; with
    ``validation_band`` 3 the same records validate within 1 %, as the UVLM alone does, and the ROM reports the
    tone's RMS share (0.1 / sqrt(1.01) of the GAC, within 3 %: the tone is off the DFT bins and scaled to the whole
    record's RMS) with a warning. A band below k_max is
    refused."""
    mesh, shapes = _synthetic()
    kw = dict(na=6, nb=6, n_steps=1200, reduce_order=None, nrmse_tol=0.05)
    with pytest.raises(TrainingError, match="output"):
        train_rom(mesh, shapes, 0.6, _OutOfBandTone(), **kw)
    rom = train_rom(mesh, shapes, 0.6, _OutOfBandTone(), validation_band=3.0, **kw)
    assert rom.validation_nrmse.max() < 0.01 and rom.validation_band == 3.0
    np.testing.assert_allclose(rom.validation_distortion, 0.1 / np.sqrt(1.01), rtol=0.03)
    assert any("outside the excitation band" in w for w in rom.warnings)
    assert rom.summary()["validation_band"] == 3.0
    np.testing.assert_allclose(rom.validation_error(rom.predicted_validation), rom.validation_nrmse, rtol=1e-12)
    with pytest.raises(ValueError, match="validation_band"):
        train_rom(mesh, shapes, 0.6, _OutOfBandTone(), validation_band=1.0, **kw)
