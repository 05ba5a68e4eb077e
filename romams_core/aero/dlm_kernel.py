"""Compiled unsteady increment of the doublet-lattice AIC for a planar lattice (Rodden's parabolic DLM).

For boxes and receivers in one plane (no dihedral) the nonplanar part of the kernel vanishes (T2 = 0) and only
the planar kernel K1 is needed, at three points of each box's doublet line (its ends and its midpoint); the
parabola through them is integrated in closed form along the line (derivation in docs/aerodynamics.md, 10.5).
panelaero evaluates the same formulation for general (nonplanar) lattices on [n, n] arrays and stays the
reference of the tests (tests/test_dlm.py) and the source of the steady VLM part; this kernel skips the nonplanar
terms and the array temporaries (about 6x faster, measured in docs/aerodynamics.md 10.5).

Units: lengths in any consistent unit (the aerogrid's), ``k`` = omega / V in the inverse of that unit; the result is
normal velocity / V per unit pressure coefficient, with the steady part (k = 0) subtracted.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from romams_core.aero.protocol import check_mach

__all__ = ["planar_dlm_increment"]

#: Laschka's exponential approximation of u / sqrt(1 + u^2): 1 - u / sqrt(1 + u^2) ~ sum a_n exp(-n c u), u >= 0
#: (the 11 published coefficients, as tabulated by Rodden et al. 1971 and Blair 1992).
LASCHKA_A = np.array([0.24186198, -2.7918027, 24.991079, -111.59196, 271.43549, -305.75288,
                      -41.183630, 545.98537, -644.78155, 328.72755, -64.279511])
LASCHKA_C = 0.372


@numba.njit(cache=True)
def _laschka_sums(u: float, k1: float, a: np.ndarray, c: float) -> tuple[complex, complex]:
    """Laschka's series S(u) = sum a_n exp(-n c u) (n c - i k1) / (n^2 c^2 + k1^2) at u >= 0 and at 0."""
    s_u, s_0 = 0.0j, 0.0j
    q = math.exp(-c * u)
    qn = 1.0
    for n in range(1, a.size + 1):
        qn *= q  # exp(-n c u)
        nc = n * c
        term = a[n - 1] * complex(nc, -k1) / (nc * nc + k1 * k1)
        s_u += qn * term
        s_0 += term
    return s_u, s_0


@numba.njit(cache=True)
def _k1(x0: float, r1: float, k: float, mach: float, a: np.ndarray, c: float) -> tuple[complex, float]:
    """Planar kernel K1 and its steady value K10 at streamwise offset x0 and lateral distance r1 > 0."""
    beta2 = 1.0 - mach * mach
    big_r = math.sqrt(x0 * x0 + beta2 * r1 * r1)
    u1 = (mach * big_r - x0) / (beta2 * r1)
    k1 = k * r1
    ejku = complex(math.cos(k1 * u1), -math.sin(k1 * u1))  # exp(-i k1 u1)
    root = math.sqrt(1.0 + u1 * u1)
    s_u, s_0 = _laschka_sums(abs(u1), k1, a, c)
    # I1(u) = (1 - u / sqrt(1 + u^2) - i k1 S(u)) exp(-i k1 u), u >= 0; a negative u by the reflection
    # I1(u) = 2 Re I1(0) - Re I1(|u|) + i Im I1(|u|)
    if u1 >= 0.0:
        i1 = (1.0 - u1 / root - 1j * k1 * s_u) * ejku
    else:
        pos = (1.0 + u1 / root - 1j * k1 * s_u) * ejku.conjugate()
        i1 = complex(2.0 * (1.0 - 1j * k1 * s_0).real - pos.real, pos.imag)
    return -i1 - ejku * mach * r1 / (big_r * root), -1.0 - x0 / big_r


@numba.njit(cache=True)
def _p1(xbar: float, ybar: float, ebar: float, tan_sweep: float, k: float, mach: float, shift: complex,
        a: np.ndarray, c: float) -> complex:
    """Planar kernel numerator P1 = -(K1 exp(-i k x0) - K10) at the point ``ebar`` of a doublet line, with
    ``shift`` = exp(-i k x0) (x0 = xbar - ebar tan_sweep)."""
    x0 = xbar - ebar * tan_sweep
    r1 = abs(ybar - ebar)
    if r1 == 0.0:  # on the line's own extension: the limits of K1 and K10
        k1_full = -2.0 + 0.0j if xbar >= 0.0 else 0.0j
        k10 = -1.0 - x0 / abs(x0)
    else:
        k1_full, k10 = _k1(x0, r1, k, mach, a, c)
    return -(k1_full * shift - k10)


@numba.njit(cache=True)
def _increment(recv: np.ndarray, load: np.ndarray, p_minus: np.ndarray, p_plus: np.ndarray, chord: np.ndarray,
               mach: float, k: float, a: np.ndarray, c: float) -> np.ndarray:
    """AIC increment [R, S] of receivers [R, 2] (x, y) and boxes (load point, line ends [S, 2], chord [S])."""
    n_r, n_s = recv.shape[0], load.shape[0]
    out = np.empty((n_r, n_s), dtype=np.complex128)
    for s in range(n_s):
        e = 0.5 * abs(p_plus[s, 1] - p_minus[s, 1])
        tan_sweep = (p_plus[s, 0] - p_minus[s, 0]) / (2.0 * e)
        end_shift = complex(math.cos(k * e * tan_sweep), math.sin(k * e * tan_sweep))  # exp(+i k e tan_sweep)
        scale = chord[s] / (8.0 * math.pi)
        for r in range(n_r):
            xbar = recv[r, 0] - load[s, 0]
            ybar = recv[r, 1] - load[s, 1]
            mid = complex(math.cos(k * xbar), -math.sin(k * xbar))  # exp(-i k xbar)
            pm = _p1(xbar, ybar, -e, tan_sweep, k, mach, mid * end_shift.conjugate(), a, c)
            p0 = _p1(xbar, ybar, 0.0, tan_sweep, k, mach, mid, a, c)
            pp = _p1(xbar, ybar, e, tan_sweep, k, mach, mid * end_shift, a, c)
            a1 = (pm - 2.0 * p0 + pp) / (2.0 * e * e)
            b1 = (pp - pm) / (2.0 * e)
            f = 2.0 * e / (ybar * ybar - e * e)
            log_ratio = math.log((ybar - e) ** 2 / (ybar + e) ** 2)
            out[r, s] = scale * ((ybar * ybar * a1 + ybar * b1 + p0) * f + (0.5 * b1 + ybar * a1) * log_ratio
                                 + 2.0 * e * a1)
    return out


def planar_dlm_increment(receivers: np.ndarray, boxes: dict[str, np.ndarray], mach: float, k: float) -> np.ndarray:
    """Unsteady AIC increment [R, S] (normal velocity / V per unit cp) of a planar lattice (grid units; k per unit).

    ``receivers`` [R, 3] collocation points; ``boxes`` a panelaero-style aerogrid (``offset_l`` load points,
    ``offset_P1`` / ``offset_P3`` doublet-line ends, left to right, ``l`` chords), every point at the same z.
    """
    load = np.asarray(boxes["offset_l"], dtype=float)
    p_minus = np.asarray(boxes["offset_P1"], dtype=float)
    p_plus = np.asarray(boxes["offset_P3"], dtype=float)
    z = np.concatenate([receivers[:, 2], load[:, 2], p_minus[:, 2], p_plus[:, 2]])
    if np.ptp(z) > 1e-9 * max(1.0, float(np.abs(z).max())):
        raise ValueError("receivers / boxes: the compiled DLM kernel needs a planar lattice (all z equal)")
    mach = check_mach(mach, upper=1.0)
    xy = np.ascontiguousarray
    with np.errstate(all="ignore"):
        return _increment(xy(receivers[:, :2], dtype=float), xy(load[:, :2]), xy(p_minus[:, :2]),
                          xy(p_plus[:, :2]), xy(np.asarray(boxes["l"], dtype=float)), float(mach), float(k),
                          LASCHKA_A, LASCHKA_C)


def warm_up() -> None:
    """Compile the kernel (or load it from numba's cache): ``make install`` and the image build fill the cache."""
    ends = np.array([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    boxes = {"offset_l": ends.mean(0, keepdims=True), "offset_P1": ends[:1], "offset_P3": ends[1:],
             "l": np.ones(1)}
    planar_dlm_increment(np.array([[0.5, 0.5, 0.0]]), boxes, 0.5, 0.1)
