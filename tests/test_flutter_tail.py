"""The flutter point does not depend on the sweep beyond the first unstable grid point.

Tracking steps after the first bracketed crossing of Re(s) = 0 (and their split sub-steps) only shape the
post-flutter V-g curves. Extending the sweep range (twice the range with twice the points, the same grid up
to the original end to rounding) must therefore leave the flutter point and the V-g data up to the crossing
unchanged, and the V-g arrays keep every coarse grid point.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_flutter_fast import OMEGA4, random_rom  # the same random coupled ROMs

from romams_core.flutter import flutter_analysis

KW = dict(zeta=0.01, a_ref=300.0, rho_ref=1.0)
Q_END = 4.0 * 0.5 * 1.0 * (0.8 * 300.0) ** 2  # the default q_max of these searches (Pa)


@pytest.mark.parametrize("seed", [0, 1, 2, 5, 7])
def test_flutter_point_independent_of_the_sweep_after_the_crossing(seed):
    """q_max doubled with 2 x n_points: same flutter point (1e-9), mode, SDOFF, and V-g up to the crossing."""
    rom = random_rom(seed)
    a = flutter_analysis(OMEGA4, rom, 1.0, 0.8, q_max=Q_END, n_points=12, **KW)
    b = flutter_analysis(OMEGA4, rom, 1.0, 0.8, q_max=2.0 * Q_END, n_points=24, **KW)
    assert a.flutter_found and b.flutter_found
    assert a.flutter_mode == b.flutter_mode and a.sdoff == b.sdoff
    for f in ("q_flutter_pa", "v_flutter_m_s", "omega_flutter_rad_s", "energy_share"):
        assert getattr(b, f) == pytest.approx(getattr(a, f), rel=1e-9), f
    np.testing.assert_allclose(b.q[:12], a.q, rtol=1e-12)
    i_cross = int(np.searchsorted(a.q, a.q_flutter_pa))  # first grid point at or above the flutter point
    np.testing.assert_allclose(b.g[:i_cross + 1], a.g[:i_cross + 1], atol=1e-9)
    np.testing.assert_allclose(b.omega[:i_cross + 1], a.omega[:i_cross + 1], rtol=1e-9, atol=1e-9)
    # the V-g data keep all coarse points, finite, also after the crossing
    assert a.g.shape == (12, 4) and b.g.shape == (24, 4)
    assert np.isfinite(a.g).all() and np.isfinite(b.g).all() and np.isfinite(b.omega).all()
