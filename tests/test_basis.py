"""PCA basis, MAC and projection on synthetic data with known answers."""

from dataclasses import dataclass

import numpy as np
import pytest

from romams_core.basis import (
    build_basis,
    mac,
    mac_matrix,
    project,
    random_designs,
    sample_designs,
)


def test_mac_of_known_pairs():
    assert mac(np.array([1.0, 0.0]), np.array([1.0, 1.0])) == pytest.approx(0.5, abs=1e-15)
    assert mac(np.array([1.0, 2.0, 3.0]), np.array([-2.0, -4.0, -6.0])) == pytest.approx(1.0, abs=1e-15)
    assert mac(np.array([1.0, 0.0, 0.0]), np.array([0.0, 3.0, 0.0])) == 0.0
    # cos^2 of the angle between the vectors: (1,1,0) vs (1,0,0) -> 1/2; (1,2,2) vs (0,0,1) -> 4/9
    a = np.array([[1.0, 1.0], [1.0, 2.0], [0.0, 2.0]])
    b = np.array([[1.0, 0.0], [0.0, 0.0], [0.0, 1.0]])
    np.testing.assert_allclose(mac(a, b), [0.5, 4.0 / 9.0], atol=1e-15)
    m = mac_matrix(a, b)
    np.testing.assert_allclose(m, [[0.5, 0.0], [1.0 / 9.0, 4.0 / 9.0]], atol=1e-15)
    assert mac(np.zeros(3), np.ones(3)) == 0.0


def test_mac_rejects_mismatch_and_nan():
    with pytest.raises(ValueError, match="b: shape"):
        mac(np.ones((4, 2)), np.ones((4, 3)))
    with pytest.raises(ValueError, match="a: contains NaN"):
        mac(np.array([1.0, np.nan]), np.ones(2))


def _low_rank_family(n_nodes=200, rank=5, n_snap=60, seed=3):
    rng = np.random.default_rng(seed)
    gen = rng.normal(size=(n_nodes, rank))
    coef = rng.normal(size=(rank, n_snap))
    return gen, gen @ coef


def test_basis_recovers_exactly_low_rank_family():
    gen, snaps = _low_rank_family()
    basis = build_basis(snaps, mac_threshold=1.0 - 1e-9, max_basis=12, n_modes=4)
    assert basis.n_basis == 5
    assert not basis.capped
    assert basis.min_mac >= 1.0 - 1e-12
    np.testing.assert_allclose(basis.shapes.T @ basis.shapes, np.eye(5), atol=1e-12)
    # the generators lie in the span of the basis
    proj = project(basis.shapes, gen, mac_threshold=0.999)
    np.testing.assert_allclose(proj.mac, 1.0, atol=1e-12)
    np.testing.assert_allclose(proj.fitted, gen, atol=1e-10)
    # with 4 shapes a 5-dimensional family is not fitted exactly; beyond the rank MAC stays 1
    assert basis.min_mac_by_m[3] < 1.0 - 1e-6
    np.testing.assert_allclose(basis.min_mac_by_m[4:], basis.min_mac_by_m[4], atol=0)
    assert basis.min_mac_by_m.shape == (12,)
    assert basis.mac_by_m is basis.min_mac_by_m
    assert basis.mac_table.shape == (60,)
    assert basis.mac_by_mode.shape == (15, 4)
    assert basis.singular_values[5] < 1e-12 * basis.singular_values[0]


def test_vectorized_snapshot_macs_match_explicit_least_squares():
    rng = np.random.default_rng(7)
    x = np.linspace(0.0, 1.0, 80)[:, None]
    a = rng.uniform(0.5, 3.0, size=30)
    snaps = np.sin(np.pi * a * x) * np.exp(-a * x)  # a smooth, not exactly low-rank family
    basis = build_basis(snaps, mac_threshold=0.999, max_basis=6)
    u, _, _ = np.linalg.svd(snaps / np.linalg.norm(snaps, axis=0), full_matrices=False)
    for m in range(1, 7):
        fit = u[:, :m] @ np.linalg.lstsq(u[:, :m], snaps, rcond=None)[0]
        assert basis.min_mac_by_m[m - 1] == pytest.approx(mac(fit, snaps).min(), abs=1e-12)
    m = basis.n_basis
    assert basis.min_mac_by_m[m - 1] >= 0.999
    assert m == 1 or basis.min_mac_by_m[m - 2] < 0.999
    np.testing.assert_allclose(basis.mac_table, mac(u[:, :m] @ (u[:, :m].T @ snaps), snaps), atol=1e-12)


def test_cap_is_reported_not_hidden():
    _, snaps = _low_rank_family()
    basis = build_basis(snaps, mac_threshold=0.9999, max_basis=2)
    assert basis.capped
    assert basis.n_basis == 2
    assert basis.min_mac < 0.9999
    assert "NOT reached" in basis.message


def test_basis_is_invariant_to_snapshot_sign_and_scale():
    _, snaps = _low_rank_family(rank=3, n_snap=12)
    b1 = build_basis(snaps, mac_threshold=0.99)
    scaled = snaps * np.array([-2.0, 1e-3, 5.0] * 4)
    b2 = build_basis(scaled, mac_threshold=0.99)
    assert b1.n_basis == b2.n_basis
    np.testing.assert_allclose(b1.shapes, b2.shapes, atol=1e-10)  # canonical sign makes it deterministic


def test_projection_of_basis_vector_and_of_orthogonal_shape():
    _, snaps = _low_rank_family(rank=4, n_snap=20)
    basis = build_basis(snaps, mac_threshold=1.0 - 1e-9)
    v = basis.shapes
    p = project(v, 3.0 * v[:, 2])
    np.testing.assert_allclose(p.gamma[:, 0], [0.0, 0.0, 3.0, 0.0], atol=1e-12)
    assert p.mac[0] == pytest.approx(1.0, abs=1e-14)
    assert p.ok
    # a shape orthogonal to the basis is flagged, never silently accepted
    rng = np.random.default_rng(1)
    w = rng.normal(size=v.shape[0])
    w -= v @ (v.T @ w)
    q = project(v, np.column_stack([v[:, 0], w]), mac_threshold=0.98)
    assert q.poor_fit == [False, True]
    assert q.mac[1] < 1e-20
    assert q.min_mac == q.mac[1]
    assert not q.ok


def test_projection_onto_non_orthonormal_basis_uses_least_squares():
    rng = np.random.default_rng(2)
    v = rng.normal(size=(50, 4))  # not orthonormal
    gamma = rng.normal(size=(4, 3))
    p = project(v, v @ gamma)
    np.testing.assert_allclose(p.gamma, gamma, atol=1e-12)
    np.testing.assert_allclose(p.mac, 1.0, atol=1e-12)
    with pytest.raises(ValueError, match="basis_shapes: rank deficient"):
        project(np.column_stack([v[:, 0], 2.0 * v[:, 0]]), v)


def test_build_basis_rejects_bad_input():
    with pytest.raises(ValueError, match="snapshots: contains NaN"):
        build_basis(np.array([[1.0, np.nan], [0.0, 1.0]]))
    with pytest.raises(ValueError, match="mac_threshold"):
        build_basis(np.eye(3), mac_threshold=1.5)
    with pytest.raises(ValueError, match="max_basis"):
        build_basis(np.eye(3), max_basis=0)
    with pytest.raises(ValueError, match="snapshots: columns \\[1\\] are zero"):
        build_basis(np.array([[1.0, 0.0], [0.0, 0.0], [1.0, 0.0]]))
    with pytest.raises(ValueError, match="n_modes"):
        build_basis(np.eye(6)[:, :5], n_modes=2)
    with pytest.raises(ValueError, match="shapes: has 3 nodes"):
        project(np.eye(4)[:, :2], np.ones((3, 1)))


@dataclass
class _Var:
    name: str
    lower: float
    upper: float


@dataclass
class _Bounds:
    """Only the design-variable bounds, which is all the samplers read."""

    design_variables: tuple


def test_latin_hypercube_is_stratified_scaled_and_seeded():
    wing = _Bounds((_Var("a", 0.15, 0.7), _Var("b", 0.0, 0.105), _Var("c", 0.5, 2.0)))
    x = sample_designs(wing, 25, seed=4)
    assert x.shape == (25, 3)
    lo, hi = np.array([0.15, 0.0, 0.5]), np.array([0.7, 0.105, 2.0])
    strata = np.floor((x - lo) / (hi - lo) * 25).astype(int)
    for j in range(3):  # one sample in each of the 25 equal bins of every variable
        assert sorted(strata[:, j]) == list(range(25))
    np.testing.assert_array_equal(x, sample_designs(wing, 25, seed=4))
    assert not np.allclose(x, sample_designs(wing, 25, seed=5))
    h = random_designs(wing, 20, seed=9)
    assert h.shape == (20, 3) and np.all((h >= lo) & (h <= hi))
    with pytest.raises(ValueError, match="samples"):
        sample_designs(wing, 0)
    with pytest.raises(ValueError, match="wing.design_variables"):
        sample_designs(_Bounds(()), 5)
