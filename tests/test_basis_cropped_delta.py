"""PCA basis of the cropped delta wing (paper section 3.1): 25 LHS samples x 4 modes, hold-out fit."""

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from romams_core.basis import (
    build_basis,
    build_basis_for_wing,
    holdout_macs,
    mac_by_basis_size,
    random_designs,
    sample_designs,
    snapshot,
)
from romams_core.wing import template


@pytest.fixture(scope="module")
def wing():
    return template("cropped-delta")


@pytest.fixture(scope="module")
def basis(wing):
    return build_basis_for_wing(wing, samples=25, modes=4, mac_threshold=0.995, max_basis=8, seed=0)


def test_eight_or_fewer_shapes_fit_held_out_designs_to_mac_099(wing, basis):
    # the paper reached MAC 0.987 on mode 4 with 8 shapes; the target here is >= 0.99 with <= 8
    assert not basis.capped, basis.message
    assert basis.n_basis <= 8
    assert basis.min_mac >= 0.995
    held_out = random_designs(wing, 20, seed=12345)
    assert not np.any(np.all(np.isclose(held_out[:, None, :], basis.designs[None]), axis=2))
    macs = holdout_macs(wing, basis.shapes, held_out, n_modes=4)  # [20, 4]
    assert macs.shape == (20, 4)
    assert macs.min() >= 0.99, macs.min(axis=0)


def test_basis_bookkeeping(wing, basis):
    n = (wing.planform.n_chord + 1) * (wing.planform.n_span + 1)
    assert basis.shapes.shape == (n, basis.n_basis)
    np.testing.assert_allclose(basis.shapes.T @ basis.shapes, np.eye(basis.n_basis), atol=1e-12)
    assert basis.designs.shape == (25, len(wing.design_variables))
    np.testing.assert_array_equal(basis.designs, sample_designs(wing, 25, seed=0))
    assert basis.design_names == [v.name for v in wing.design_variables]
    assert basis.mac_table.shape == (100,) and basis.mac_by_mode.shape == (25, 4)
    assert basis.mac_table.min() == pytest.approx(basis.min_mac, abs=0)
    assert np.all(np.diff(basis.min_mac_by_m) >= -1e-15)  # more shapes never fit worse
    assert basis.min_mac_by_m[basis.n_basis - 2] < 0.995 <= basis.min_mac_by_m[basis.n_basis - 1]
    # the paper's Fig. 11 curve for one structure: MAC per mode vs basis size, reaching the projection MACs
    shapes = snapshot(wing, random_designs(wing, 1, seed=7)[0], 4)
    curves = mac_by_basis_size(basis.candidates, shapes)
    assert curves.shape == (basis.candidates.shape[1], 4)
    direct = holdout_macs(wing, basis.shapes, random_designs(wing, 1, seed=7))[0]
    np.testing.assert_allclose(curves[basis.n_basis - 1], direct, atol=1e-12)


def test_parallel_snapshots_and_progress_give_the_same_basis(wing):
    seen = []
    with ThreadPoolExecutor(2) as pool:
        par = build_basis_for_wing(wing, samples=6, modes=3, seed=3, map_fn=pool.map,
                                   progress=lambda f, msg: seen.append(f))
    ser = build_basis(np.hstack([snapshot(wing, x, 3) for x in sample_designs(wing, 6, seed=3)]), n_modes=3)
    assert par.n_basis == ser.n_basis
    np.testing.assert_allclose(par.shapes, ser.shapes, atol=1e-12)
    assert seen[0] == 0.0 and seen[-1] == 1.0 and np.all(np.diff(seen) >= 0)
