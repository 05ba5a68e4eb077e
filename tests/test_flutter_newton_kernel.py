"""The compiled continuation steps (``flutter.newton_kernel``) against the numpy steps they replace, and the default
tracker choice ("auto").

Random coupled 4-mode ROMs (as test_flutter_fast.py). ``newton_kernel.ENABLED = False`` runs the numpy path (one
``RootsRequest``, batched numpy Newton and null vectors, and the Python acceptance tests per step), its reference.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_flutter_fast import OMEGA4, random_rom

from romams_core.flutter import analysis, eigen, flutter_analysis, model, newton
from romams_core.flutter import newton_kernel as nk

KW = dict(zeta=0.01, a_ref=300.0, rho_ref=1.0)


@pytest.mark.parametrize("sweep", ["constant-speed", "constant-density", "matched"])
def test_compiled_steps_equal_the_numpy_steps(monkeypatch, sweep):
    """8 random ROMs per sweep: the same flutter point (1e-9), mode, SDOFF, coarse V-g data (1e-9) and tracked path up
    to the flutter point with the kernels as with the numpy code (matched: single compiled steps; the others: whole
    compiled segments)."""
    for seed in range(8):
        rom = random_rom(seed)
        model.PREP_CACHE.clear()
        new = flutter_analysis(OMEGA4, rom, 1.0, 0.8, sweep=sweep, tracking="continuation", **KW)
        with monkeypatch.context() as mp:
            mp.setattr(nk, "ENABLED", False)
            ref = flutter_analysis(OMEGA4, rom, 1.0, 0.8, sweep=sweep, tracking="continuation", **KW)
        assert new.flutter_found == ref.flutter_found and new.flutter_mode == ref.flutter_mode
        assert new.sdoff == ref.sdoff
        if ref.flutter_found:
            for f in ("q_flutter_pa", "v_flutter_m_s", "omega_flutter_rad_s", "energy_share"):
                assert getattr(new, f) == pytest.approx(getattr(ref, f), rel=1e-9), (seed, f)
        np.testing.assert_allclose(new.g, ref.g, atol=1e-9)
        np.testing.assert_allclose(new.omega, ref.omega, rtol=1e-9, atol=1e-9 * OMEGA4.max())
        # the tracked path up to the flutter point is the same; after it the step lengths may differ (a rounding
        # decides whether the predictor error is below 1/8 of the tolerance), so there only the grid points compare
        q_cut = new.q_flutter_pa * (1.0 + 1e-9) if new.flutter_found else np.inf
        a, b = new.curves, ref.curves
        na, nb = int(np.sum(a.q <= q_cut)), int(np.sum(b.q <= q_cut))
        assert na == nb
        np.testing.assert_array_equal(a.kind[:na], b.kind[:na])
        np.testing.assert_allclose(a.g[:na], b.g[:na], atol=1e-9)
    model.PREP_CACHE.clear()


def test_plot_points_by_newton_are_the_eigen_solves_roots(monkeypatch):
    """The plot-only points near later crossings (curves kind 4): Newton roots from the interval's end states = the
    assigned roots of full eigen-solves (1e-9 of the largest omega) on 12 random ROMs (165 points)."""
    from romams_core.flutter import curves

    n_cmp = 0
    for seed in range(12):
        rom = random_rom(seed)
        new = flutter_analysis(OMEGA4, rom, 1.0, 0.8, **KW)
        with monkeypatch.context() as mp:
            mp.setattr(curves, "_newton_points", lambda *a: None)
            ref = flutter_analysis(OMEGA4, rom, 1.0, 0.8, **KW)
        np.testing.assert_array_equal(new.curves.kind, ref.curves.kind)
        extra = new.curves.kind == 4
        same = np.abs(new.curves.omega[extra] - ref.curves.omega[extra]) <= 1e-9 * np.max(OMEGA4)
        n_cmp += int(extra.sum())
        assert same.all(), (seed, same.mean())  # measured: all within 2.4e-11 rad/s on these 12 ROMs
    assert n_cmp > 0


def test_auto_tracking_is_the_continuation_where_its_steps_are_compiled():
    """Default "auto": the continuation on a diagonalized Tustin model with a constant-speed or constant-density
    sweep, the eigen tracker with the matched sweep and the zero-order hold; a name given is kept."""
    rom = random_rom(1)
    pick = {}
    for name, kw in {"speed": {}, "density": {"sweep": "constant-density"}, "matched": {"sweep": "matched"},
                     "zoh": {"coupling": "zoh"}, "given": {"tracking": "eigen"}}.items():
        search = analysis.prepare_search(OMEGA4, rom, 1.0, 0.8, **{**KW, **kw})
        pick[name] = search.tracking
    assert pick == {"speed": "continuation", "density": "continuation", "matched": "eigen", "zoh": "eigen",
                    "given": "eigen"}


def test_auto_gives_the_eigen_trackers_flutter_points():
    """12 random ROMs, default (constant-speed: compiled continuation) against tracking="eigen": the same flutter
    point to 1e-9, mode, SDOFF and modal shares (the post-flutter V-g points may follow other roots)."""
    for seed in range(12):
        rom = random_rom(seed)
        new = flutter_analysis(OMEGA4, rom, 1.0, 0.8, **KW)
        ref = flutter_analysis(OMEGA4, rom, 1.0, 0.8, tracking="eigen", **KW)
        assert new.flutter_found == ref.flutter_found and new.flutter_mode == ref.flutter_mode
        assert new.sdoff == ref.sdoff and new.single_mode_unstable == ref.single_mode_unstable
        if ref.flutter_found:
            for f in ("q_flutter_pa", "v_flutter_m_s", "omega_flutter_rad_s"):
                assert getattr(new, f) == pytest.approx(getattr(ref, f), rel=1e-9), (seed, f)
            np.testing.assert_allclose(new.modal_share, ref.modal_share, atol=1e-9)


def test_lu_solve_equals_numpy_and_flags_an_exactly_singular_matrix():
    """The k x k complex LU of the kernels solves as numpy does (1e-12); an exactly singular matrix is flagged, or
    (inverse iteration) its zero pivot perturbed so that the solve stays finite."""
    rng = np.random.default_rng(5)
    a = rng.standard_normal((4, 4)) + 1j * rng.standard_normal((4, 4))
    b = rng.standard_normal((4, 3)) + 1j * rng.standard_normal((4, 3))
    lu, piv, sing = nk._lu(a, False)
    assert not sing
    np.testing.assert_allclose(nk._lu_solve(lu, piv, b), np.linalg.solve(a, b), rtol=1e-12, atol=1e-12)
    a[:, 3] = 0.0  # exactly singular: the last pivot is exactly 0 after the elimination
    assert nk._lu(a, False)[2]
    lu, piv, sing = nk._lu(a, True)
    assert not sing and np.isfinite(nk._lu_solve(lu, piv, b)).all()


def test_compiled_vectors_and_roots_equal_the_numpy_ones(monkeypatch):
    """``newton_kernel.vectors`` (structural vectors, content, lag flags of eigenvalues) = the numpy path of
    ``eigen.struct_vectors`` on a random model's full spectrum (MAC 1 - 1e-10, content 1e-10), and
    ``newton_kernel.roots_vectors`` = the batched numpy Newton of ``newton.roots_and_vectors`` (roots 1e-12)."""
    m = model.make_model(OMEGA4, np.full(4, 0.01), 1.0, random_rom(2), "tustin")
    assert m.lam_a is not None
    v, q = np.array([240.0, 240.0, 240.0]), np.array([1000.0, 4000.0, 9000.0])
    lam = np.linalg.eigvals(eigen._tustin_matrices(m, v, q))
    sel = np.abs(lam[0] - 1j * OMEGA4[:, None]).argmin(axis=1)
    reqs = [newton.RootRequest(m, 240.0, 1000.0, complex(lam[0, j]) * (1 + 1e-3), float(OMEGA4[i]))
            for i, j in enumerate(sel)]
    fast = eigen.struct_vectors(m, lam, v, q)
    roots, data = newton.roots_and_vectors(reqs, np.ones(4, bool))
    with monkeypatch.context() as mp:
        mp.setattr(nk, "ENABLED", False)
        ref = eigen.struct_vectors(m, lam, v, q)
        roots_ref, data_ref = newton.roots_and_vectors(reqs, np.ones(4, bool))
    assert fast is not None and ref is not None
    mac = np.abs(np.sum(fast[0].conj() * ref[0], axis=1)) ** 2
    np.testing.assert_allclose(mac, 1.0, atol=1e-10)
    np.testing.assert_allclose(fast[1], ref[1], atol=1e-10)
    np.testing.assert_array_equal(fast[2], ref[2])
    np.testing.assert_allclose(roots, roots_ref, rtol=1e-12)
    for d, dr in zip(data, data_ref, strict=True):
        assert abs(np.vdot(d[0], dr[0])) ** 2 == pytest.approx(1.0, abs=1e-10)
        assert d[1] == pytest.approx(dr[1], abs=1e-10) and d[2] == dr[2]


def test_warm_up_compiles_the_signatures_the_searches_use():
    """After ``warm_up`` (make install, the image, a worker's start) searches of all three sweeps add no compiled
    signature: no evaluation waits for a compilation."""
    nk.warm_up()
    before = {f: len(getattr(nk, f).signatures) for f in ("segment", "newton_point", "roots_vectors", "vectors")}
    for sweep in ("constant-speed", "constant-density", "matched"):
        flutter_analysis(OMEGA4, random_rom(1), 1.0, 0.8, sweep=sweep, tracking="continuation", **KW)
    after = {f: len(getattr(nk, f).signatures) for f in before}
    assert after == before and all(n >= 1 for n in after.values())
