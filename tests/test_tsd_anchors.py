"""A TSD training with anchors: the stored ROM reproduces the direct TSD response (step records) at the anchor k,
which a harmonic run confirms."""

from __future__ import annotations

import inspect
import math

import numpy as np
import pytest

from benchmarks.tsd_harmonic_check import harmonic_column
from romams.serialize import dumps, loads
from romams_core.aero.tsd import TsdSolver
from romams_core.aero.tsd.grid import GridSpec
from romams_core.errors import InputError
from romams_core.mesh import Planform, standard_mesh
from romams_core.training import TrainingError
from romams_core.training_tsd import ANCHOR_BAND_K, DEFAULT_ANCHOR_K, _anchor, anchors_on, train_tsd_rom

PLANFORM = Planform(root_chord=0.559, tip_chord=0.368, semispan=0.762, sweep_le=math.radians(46.7),
                    n_chord=10, n_span=12)
SMALL = GridSpec(n_chord=16, n_upstream=6, n_downstream=8, n_span=6, n_outboard=4, n_z=10, dz0=0.04)


def test_anchored_tsd_rom_reproduces_direct_harmonic_runs():
    """Two shapes at M 0.8 on a small grid, anchors at k 0.1 / 0.2 from the step records: the ROM meets its stored
    anchors to 1e-8; the anchors agree with an independent single-tone run at k 0.2 within 1 %; the anchored ROM
    is checked over the k band (``anchor_band_error`` below 2 %); the free-run validation stays within 1 point of
    percent of the unanchored ROM's; the anchors survive storage; anchors 10x off are refused; the default is
    anchored (``DEFAULT_ANCHOR_K``), and None or [] trains a plain ROM that warns."""
    mesh = standard_mesh(PLANFORM)
    eta = mesh.y / PLANFORM.semispan
    shapes = np.column_stack([0.01 * eta**2, 0.01 * eta * (mesh.x - mesh.x.mean()) / PLANFORM.root_chord])
    solver = TsdSolver(grid=SMALL, record_threads=2)
    kw = dict(na=4, nb=4, n_steps=600, nrmse_tol=0.2)
    plain = train_tsd_rom(mesh, shapes, 0.8, solver, anchor_k=None, **kw)
    rom = train_tsd_rom(mesh, shapes, 0.8, solver, anchor_k=[0.2, 0.1], anchor_hold=60.0, **kw)
    np.testing.assert_array_equal(rom.anchor_k, [0.1, 0.2])
    gaf = rom.anchor_gaf
    assert gaf.shape == (2, 2, 2) and np.iscomplexobj(gaf)
    np.testing.assert_allclose(rom.ss.freqresp(rom.anchor_k), gaf, atol=1e-8 * np.abs(gaf).max())
    direct = harmonic_column(solver, mesh, shapes, 0.8, 0.2, 1)  # one tone, two periods
    assert np.abs(direct - gaf[1, :, 1]).max() < 0.01 * np.abs(direct).max()
    assert rom.ss.n_states == plain.ss.n_states + 3 * 2
    assert np.max(rom.validation_nrmse) < np.max(plain.validation_nrmse) + 0.01
    assert any("anchored" in w for w in rom.warnings) and rom.summary()["anchor_k"] == [0.1, 0.2]
    assert plain.anchor_band_error is None and 0.0 < rom.summary()["anchor_band_error"] < 0.02
    assert rom.anchor_band_gaf.shape == (len(ANCHOR_BAND_K), 2, 2)  # kept: a later re-anchoring needs no TSD run
    np.testing.assert_array_equal(rom.anchor_band_k, ANCHOR_BAND_K)
    assert not any(w.startswith("not anchored") for w in rom.warnings)
    assert any(w.startswith("not anchored") for w in plain.warnings)
    back = loads(*dumps(rom))
    np.testing.assert_array_equal(back.anchor_gaf, gaf)
    np.testing.assert_array_equal(back.anchor_band_gaf, rom.anchor_band_gaf)
    with pytest.raises(TrainingError, match="anchored at k"):  # anchors that contradict the records
        _anchor(plain, rom.anchor_k, 10.0 * gaf)
    with pytest.raises(InputError, match="anchor_k"):
        train_tsd_rom(mesh, shapes, 0.8, solver, anchor_k=[0.0, 0.1], **kw)
    with pytest.raises(InputError, match="anchor_hold"):
        train_tsd_rom(mesh, shapes, 0.8, solver, anchor_hold=5.0, **kw)
    assert inspect.signature(train_tsd_rom).parameters["anchor_k"].default == DEFAULT_ANCHOR_K == (0.025, 0.05, 0.1)
    assert not anchors_on(None) and not anchors_on([]) and anchors_on([0.05])


def test_hold_differences_of_a_first_order_lag():
    """``benchmarks.tsd_step_hold``: a first-order lag's step record (time constant 20 t*) truncated at 60 and 100
    t* misses the 240 t* record's gain by a^600 - a^2400 and a^1000 - a^2400 (a = exp(-0.1 / 20)): the k = 0
    differences have that ratio (about e^2) to 1e-9, and the longest hold differs from itself by zero."""
    from benchmarks.tsd_step_hold import hold_differences

    a = math.exp(-0.1 / 20.0)
    n = np.arange(2401)
    u = (n >= 1).astype(float)
    y = np.where(n >= 1, 1.0 - a ** n, 0.0)[:, None] * np.array([1.0, 0.5])
    rec = np.column_stack([u, np.zeros_like(u)])
    diff = hold_differences([y], [rec], [0], [60.0, 100.0, 240.0], np.array([0.0, 0.01]))
    assert diff["240"] == [0.0, 0.0]
    ratio = (a ** 600 - a ** 2400) / (a ** 1000 - a ** 2400)
    assert diff["60"][0] / diff["100"][0] == pytest.approx(ratio, rel=1e-9)
    assert diff["60"][1] > diff["100"][1] > 0.0


def test_anchors_that_contradict_the_records_leave_the_plain_rom(monkeypatch):
    """When the anchored model misses the validation tolerance (here: the step records' transfer matrix scaled by
    10, records that contradict the training's), the training keeps the plain ROM with both warnings and its error
    against the step records over the band, instead of failing."""
    import romams_core.training_tsd as tt

    mesh = standard_mesh(PLANFORM)
    eta = mesh.y / PLANFORM.semispan
    shapes = np.column_stack([0.01 * eta**2, 0.01 * eta * (mesh.x - mesh.x.mean()) / PLANFORM.root_chord])
    solver = TsdSolver(grid=SMALL, record_threads=2)
    kw = dict(na=4, nb=4, n_steps=600, nrmse_tol=0.2, anchor_hold=60.0)
    real = tt.step_anchors
    monkeypatch.setattr(tt, "step_anchors", lambda *a, **k: 10.0 * real(*a, **k))
    rom = train_tsd_rom(mesh, shapes, 0.8, solver, anchor_k=[0.1, 0.2], **kw)
    plain = train_tsd_rom(mesh, shapes, 0.8, solver, anchor_k=None, **kw)
    assert rom.anchor_k is None and rom.ss.n_states == plain.ss.n_states
    np.testing.assert_allclose(rom.validation_nrmse, plain.validation_nrmse, rtol=1e-9)
    assert any(w.startswith("the step records contradict the training records (anchored at k") for w in rom.warnings)
    assert any(w.startswith("not anchored") for w in rom.warnings)
    assert 0.8 < rom.anchor_band_error < 1.0  # the plain ROM is 90 % off records scaled by 10
