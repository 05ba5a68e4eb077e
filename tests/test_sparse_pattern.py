"""Fixed-pattern assembly (``sparse_pattern``, ``plate_cache``): the same matrices as the general COO assembly
(to 1e-14 of the largest entry, summation order only), the same modes, the pattern shared read-only between
designs, and the general path where a group leaves the pattern."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from romams_core.basis import random_designs
from romams_core.mesh import standard_mesh
from romams_core.structure import modal
from romams_core.structure.plate_cache import clear_cache, topology
from romams_core.structure.sparse_pattern import FreePart, Pattern
from romams_core.wing import cropped_delta, template


def _coo(conn: np.ndarray, vals: np.ndarray, n: int) -> sp.csc_matrix:
    return modal._assemble_many([(conn, vals)], n)


def test_pattern_sums_like_coo_and_cuts_the_free_block():
    rng = np.random.default_rng(3)
    conn = np.array([[0, 1, 2], [1, 2, 3], [3, 4, 5], [0, 5, 6]])
    vals = rng.standard_normal((4, 3, 3))
    vals = vals + vals.transpose(0, 2, 1)
    pat = Pattern.of([conn], 7)
    k = pat.matrix([pat.positions(conn)], [vals])
    ref = _coo(conn, vals, 7)
    np.testing.assert_allclose(k.toarray(), ref.toarray(), rtol=0, atol=1e-15)
    assert k.has_sorted_indices and k.nnz == ref.nnz
    free = np.array([1, 2, 3, 5, 6])
    fp = FreePart.of(pat, free)
    np.testing.assert_array_equal(fp.block(k).toarray(), k.toarray()[np.ix_(free, free)])
    ab = fp.banded_upper(fp.block(k))
    dense = k.toarray()[np.ix_(free, free)]
    for d in range(fp.band + 1):  # LAPACK upper storage: ab[u - d, j] = A[j - d, j]
        np.testing.assert_array_equal(ab[fp.band - d, d:], np.diag(dense, d))
    assert pat.positions(np.array([[0, 4]])) is None  # 0-4 is joined by no element
    with pytest.raises(ValueError):
        pat.indices[0] = 1  # shared by every matrix on the pattern: read-only


@pytest.mark.parametrize("name", ["cropped-delta", "agard-445.6", "eccentric"])
def test_plate_models_equal_the_general_assembly(name):
    wing = cropped_delta("eccentric") if name == "eccentric" else template(name)
    mesh = standard_mesh(wing.planform)
    designs = list(random_designs(wing, 3, seed=5)) if wing.design_variables else [None]
    for x in designs:
        m = modal.build_model(wing, x, mesh)
        assert m.free_part is not None
        general = modal.FEModel(**{**m.__dict__, "free_part": None})  # the same matrices, general slicing
        om_fast, phi_fast = modal.solve_modes(m, 4)
        om_gen, phi_gen = modal.solve_modes(general, 4)
        np.testing.assert_allclose(om_fast, om_gen, rtol=1e-11)
        np.testing.assert_allclose(np.abs(phi_fast), np.abs(phi_gen), atol=1e-9 * np.abs(phi_gen).max())


@pytest.mark.parametrize("name", ["cropped-delta", "eccentric"])
def test_matrices_match_the_coo_assembly_of_the_same_groups(name):
    wing = cropped_delta("eccentric") if name == "eccentric" else template(name)
    mesh = standard_mesh(wing.planform)
    for x in random_designs(wing, 3, seed=9):  # the beam line moves the nodes; the pattern stays
        s = wing.structure_for(x)
        m = modal.build_model(wing, x, mesh)
        pm, k_parts, m_parts, mass = modal.plate_groups(wing.planform, s, m.dofs_per_node)
        k_ref, m_ref = modal._assemble_many(k_parts, m.K.shape[0]), modal._assemble_many(m_parts, m.K.shape[0])
        assert abs(m.K - k_ref).max() <= 1e-14 * abs(k_ref).max()
        assert abs(m.M - m_ref).max() <= 1e-14 * abs(m_ref).max()
        assert mass == m.mass_kg
    clear_cache()  # a fresh pattern gives the same matrices
    m2 = modal.build_model(wing, x, mesh)
    assert abs(m.K - m2.K).max() == 0.0 and abs(m.M - m2.M).max() == 0.0


def test_a_lumped_mass_outside_the_pattern_takes_the_general_assembly():
    conn = np.array([[0, 1, 2]])
    k = np.ones((1, 3, 3))
    lumped = (np.array([[0, 4]]), np.ones((1, 2, 2)))  # DOFs 0 and 4: no stiffness group joins them (nonzero)
    kk, mm, fp = modal._assemble_pair([(conn, k)], [(conn, k), lumped], 5, np.arange(1, 5))
    assert fp is None
    np.testing.assert_array_equal(mm.toarray(), _coo(conn, k, 5).toarray() + _coo(*lumped, 5).toarray())
    kk2, mm2, fp2 = modal._assemble_pair([(conn, k)], [(conn, k)], 5, np.arange(1, 5))
    assert fp2 is not None and fp2.free.tolist() == [1, 2, 3, 4]
    np.testing.assert_array_equal(kk2.toarray(), kk.toarray())
    assert topology([conn], 5, np.arange(1, 5)) is topology([conn.copy()], 5, np.arange(1, 5))  # cached by value
