"""Branch continuation by Newton on det T(s) (``tracking="continuation"``): same flutter points as the eigen-solve
tracker, far fewer full eigen-solves, batched = single, and the Newton roots' vectors are the eigen-solver's.

Random coupled 4-mode ROMs (as test_flutter_fast.py). The crossing is polished to 1e-11 after brentq, so the
flutter point does not depend on the tracked path: both trackers must give it to 1e-9 (measured: 7e-16).
"""

from __future__ import annotations

import numpy as np
import pytest
from test_flutter_fast import OMEGA4, random_rom  # the same random coupled ROMs

from romams_core.errors import InputError
from romams_core.flutter import analysis, batch, eigen, flutter_analysis, flutter_batch, model, newton

KW = dict(zeta=0.01, a_ref=300.0, rho_ref=1.0)


def _no_curves(tracker, path, flutter):  # noqa: ANN001, ANN202
    """The plot curves left out: their extra points (docs/flutter.md 8.1) cost the same eigen-solves whichever
    tracker ran, after the flutter point; the counts below are the search's."""
    return None
    yield  # a generator, as vg_curves


@pytest.fixture(autouse=True)
def _search_only(monkeypatch):
    monkeypatch.setattr(analysis, "vg_curves", _no_curves)


def _solves(fn) -> tuple[object, int]:
    """(result of fn(), full eigen-solves (matrices) of the search it took)."""
    batch.STATS.reset()
    out = fn()
    return out, batch.STATS.matrices


@pytest.mark.parametrize("sweep", ["constant-speed", "constant-density", "matched"])
def test_continuation_finds_the_eigen_trackers_flutter_points(sweep):
    """8 random ROMs per sweep: same found flag, mode, SDOFF; q_f, omega_f to 1e-9; and at most 8 full eigen-solves
    per search on average without the SDOFF sweeps (the eigen-solve tracker takes 20 to 30)."""
    counts = []
    for seed in range(8):
        rom = random_rom(seed)
        model.PREP_CACHE.clear()
        ref, n_ref = _solves(lambda rom=rom: flutter_analysis(OMEGA4, rom, 1.0, 0.8, sweep=sweep, tracking="eigen",
                                                              **KW))
        new, n_new = _solves(lambda rom=rom: flutter_analysis(OMEGA4, rom, 1.0, 0.8, sweep=sweep,
                                                              tracking="continuation", **KW))
        assert new.flutter_found == ref.flutter_found
        assert new.flutter_mode == ref.flutter_mode and new.sdoff == ref.sdoff
        if ref.flutter_found:
            for f in ("q_flutter_pa", "v_flutter_m_s", "omega_flutter_rad_s"):
                assert getattr(new, f) == pytest.approx(getattr(ref, f), rel=1e-9), (seed, f)
        counts.append((n_new, n_ref))
    n_new, n_ref = np.mean(counts, axis=0)
    assert n_new < 0.6 * n_ref


def test_continuation_uses_at_most_eight_solves_without_sdoff():
    """Without the SDOFF check (sdoff_share 1: energy shares below 1 skip it) a constant-speed search needs at
    most 8 full eigen-solves on average: the checkpoints, the crossing check and the steps Newton cannot resolve."""
    n = []
    for seed in range(12):
        _, k = _solves(lambda seed=seed: flutter_analysis(OMEGA4, random_rom(seed), 1.0, 0.8, sdoff_share=1.0,
                                                          tracking="continuation", **KW))
        n.append(k)
    assert np.mean(n) <= 8.0


def test_continuation_batch_equals_single():
    """flutter_batch with the continuation = flutter_analysis design by design (same generator code)."""
    roms = [random_rom(s) for s in range(6)]
    res_b = flutter_batch([(OMEGA4 * (1.0 + 0.02 * i), r) for i, r in enumerate(roms)], 1.0, 0.8,
                          tracking="continuation", **KW)
    for i, (b, r) in enumerate(zip(res_b, roms, strict=True)):
        s = flutter_analysis(OMEGA4 * (1.0 + 0.02 * i), r, 1.0, 0.8, tracking="continuation", **KW)
        assert b.flutter_found == s.flutter_found and b.flutter_mode == s.flutter_mode and b.sdoff == s.sdoff
        assert b.q_flutter_pa == pytest.approx(s.q_flutter_pa, rel=1e-12)
        np.testing.assert_allclose(b.g, s.g, atol=1e-12)


def test_newton_root_vectors_are_the_eigen_solvers():
    """roots_and_vectors' structural vectors and content at Newton roots = struct_vectors' at the eigenvalues
    (MAC 1 - 1e-10, content 1e-10), for the diagonalized and the dense (reference) aero form."""
    rom = random_rom(3)
    for cond_max in (model.DIAG_COND_MAX, 0.0):
        model.PREP_CACHE.clear()
        old, model.DIAG_COND_MAX = model.DIAG_COND_MAX, cond_max
        try:
            m = model.make_model(OMEGA4, np.full(4, 0.01), 1.0, rom, "tustin")
        finally:
            model.DIAG_COND_MAX = old
        v, q = np.array([240.0]), np.array([3000.0])
        ref = eigen.eig_batch(m, v, q)  # reference path: LAPACK eigenvectors when not diagonalized
        lam = ref.lam[0]
        pick = np.argsort(np.abs(lam - 1j * OMEGA4[:, None]), axis=1)[:, 0]  # the roots nearest the modes
        reqs = [newton.RootRequest(m, 240.0, 3000.0, complex(lam[j]) * (1 + 1e-4), float(OMEGA4[i]))
                for i, j in enumerate(pick)]
        roots, data = newton.roots_and_vectors(reqs, np.ones(4, bool))
        for i, j in enumerate(pick):
            assert roots[i] == pytest.approx(lam[j], rel=1e-9)
            vec, content, _ = data[i]
            mac = abs(np.vdot(ref.xs[0][:, j], vec)) ** 2
            assert mac == pytest.approx(1.0, abs=1e-10)
            assert content == pytest.approx(ref.content[0][j], abs=1e-10)
    model.PREP_CACHE.clear()


def test_unknown_tracking_is_an_input_error():
    with pytest.raises(InputError) as exc:
        flutter_analysis(OMEGA4, random_rom(0), 1.0, 0.8, tracking="newton", **KW)
    assert exc.value.field == "tracking"


@pytest.mark.parametrize("sweep", ["constant-speed", "constant-density"])
def test_without_vg_checks_the_flutter_point_is_the_same(sweep):
    """vg_checks False skips only the checkpoints after the first one past the crossing (docs/performance.md 6c):
    the same flutter point, mode and SDOFF to 1e-12, the same V-g data up to the flutter point, never more
    full eigen-solves, and fewer over the 8 ROMs."""
    n_on, n_off = 0, 0
    for seed in range(8):
        rom = random_rom(seed)
        on, k_on = _solves(lambda rom=rom: flutter_analysis(OMEGA4, rom, 1.0, 0.8, sweep=sweep, **KW))
        off, k_off = _solves(lambda rom=rom: flutter_analysis(OMEGA4, rom, 1.0, 0.8, sweep=sweep, vg_checks=False,
                                                              **KW))
        assert off.flutter_found == on.flutter_found and off.flutter_mode == on.flutter_mode
        assert off.sdoff == on.sdoff and k_off <= k_on
        if on.flutter_found:
            assert off.q_flutter_pa == pytest.approx(on.q_flutter_pa, rel=1e-12)
            assert off.omega_flutter_rad_s == pytest.approx(on.omega_flutter_rad_s, rel=1e-12)
            before = on.q < on.q_flutter_pa
            np.testing.assert_allclose(off.g[before], on.g[before], rtol=0, atol=1e-12)
        else:
            np.testing.assert_allclose(off.g, on.g, rtol=0, atol=1e-12)  # no crossing: every check runs
        n_on, n_off = n_on + k_on, n_off + k_off
    assert n_off < n_on
