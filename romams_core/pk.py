"""p-k flutter solution with a frequency-domain aerodynamic operator: the full-order reference for the ROMs.

Structure in mass-normalized modal coordinates (M = I), modal damping ratios zeta, aerodynamics as the
harmonic transfer matrix H(k) [k x k] (generalized force per unit q and unit modal amplitude, f = H(k) xi
for xi ~ e^{i omega t}), reduced frequency k = omega b / V on b = c_ref / 2 (the UVLM's convention).

British (p-k) form: for each structural branch j, find the root p of

    det(p^2 I + 2 zeta diag(omega) p + diag(omega^2) - q H(k)) = 0,   k = Im(p) b / V,

i.e. the aerodynamic matrix is the harmonic one at the root's own frequency. For fixed k the equation is a
linear eigenproblem of the complex first-order matrix [[0, I], [-(K - q H(k)), -G]]; the k of branch j is
updated from the chosen root (the one nearest the branch's previous estimate, with Im p >= 0) until
|k_new - k_old| <= k_tol (1 + k) (direct substitution; ``k_tol`` default 1e-9). Each iteration solves the
eigenproblems of all branches as one batched ``numpy.linalg.eigvals``.

Damping convention: p = omega (gamma + i), gamma = Re(p) / Im(p) (Nastran's p-k damping is g = 2 gamma),
positive = unstable. Results hold ``gamma`` (inf for a real, non-oscillatory root) and, for plots next to
the time-domain results, ``g`` = 2 Re(p) / |p| = 2 gamma / sqrt(1 + gamma^2), the very definition of
``flutter.FlutterResult.g`` (both vanish together and agree to O(gamma^3)). At the flutter point gamma = 0,
the motion is harmonic and p-k is exact (k-method and p-k coincide there); away from it gamma is the usual
p-k approximation of the damping.

Sweeps as in ``romams_core.flutter`` (the same sweep objects, ``romams_core.flutter.sweeps``):
"constant-density" (V swept at rho_ref), "constant-speed" (V = M a_ref, density swept, i.e. q) and "matched"
(altitude swept with V = M a(h)). As there, ``v_flutter_m_s`` is the true airspeed at the flutter point and
``v_eas_m_s`` the equivalent airspeed sqrt(2 q_f / rho_0). The first zero crossing of gamma on a structural
branch is refined with ``scipy.optimize.brentq``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.optimize import brentq

from romams_core.errors import InputError
from romams_core.flutter import SWEEPS, check_flutter_inputs, finite_positive
from romams_core.flutter.sweeps import eas, make_sweep, resolve_reference

DEFAULT_ALTITUDE_REF_M = 10_000.0

AeroFn = Callable[[np.ndarray], np.ndarray]


@dataclass
class AeroTable:
    """Harmonic GAC matrix H [nk, m, m] (m^3 for modes in m) tabulated at ascending reduced frequencies k [nk]."""

    k: np.ndarray
    h: np.ndarray
    mach: float = float("nan")
    description: str = ""

    def __post_init__(self) -> None:
        self.k = np.asarray(self.k, dtype=float)
        self.h = np.asarray(self.h, dtype=complex)
        if self.k.ndim != 1 or self.k.size < 4:
            raise InputError("k", f"must be a 1-D grid of at least 4 reduced frequencies, got shape {self.k.shape}")
        if not np.all(np.isfinite(self.k)) or np.any(np.diff(self.k) <= 0) or self.k[0] < 0:
            raise InputError("k", "must be finite, >= 0 and strictly ascending")
        if self.h.ndim != 3 or self.h.shape[0] != self.k.size or self.h.shape[1] != self.h.shape[2]:
            raise InputError("h", f"must have shape ({self.k.size}, m, m), got {self.h.shape}")
        if not np.all(np.isfinite(self.h)):
            raise InputError("h", "contains non-finite values")
        self._spline = CubicSpline(self.k, self.h, axis=0)

    def __call__(self, k: np.ndarray) -> np.ndarray:
        """H at reduced frequencies k [n] (cubic spline per entry; k outside the table raises ValueError)."""
        k = np.atleast_1d(np.asarray(k, dtype=float))
        lo, hi = self.k[0], self.k[-1]
        tol = 1e-9 * max(hi, 1.0)
        if np.any(k < lo - tol) or np.any(k > hi + tol):
            raise InputError("k", f"reduced frequency {float(k.min()):.6g} .. {float(k.max()):.6g} outside the "
                                  f"aerodynamic table [{lo:.6g}, {hi:.6g}]; tabulate a wider k range")
        return self._spline(np.clip(k, lo, hi))


@dataclass
class PkResult:
    """p-k flutter point and V-g data at one Mach number (SI units, rad/s).

    ``v_flutter_m_s`` is the true airspeed at the flutter point (= ``v_true_m_s``), ``v_eas_m_s`` the equivalent
    airspeed sqrt(2 q_f / rho_0); ``v`` is the sweep's speed axis (true speed for constant-density / matched,
    sqrt(2 q / rho_ref) for constant-speed), ``v_eas`` sqrt(2 q / rho_0). Per structural branch [nv, k]:
    ``gamma`` = Re(p) / Im(p) (positive = unstable, inf for a real root), ``g`` = 2 Re(p) / |p| (as
    flutter.FlutterResult.g), ``omega`` = Im(p) (rad/s), ``k_red`` = omega b / V. Scalars are None when no
    flutter was found.
    """

    mach: float
    sweep: str
    flutter_found: bool
    v_flutter_m_s: float | None
    omega_flutter_rad_s: float | None
    q_flutter_pa: float | None
    rho_flutter: float | None
    k_flutter: float | None
    v_true_m_s: float | None
    flutter_mode: int | None  # 1-based structural branch
    message: str
    rho_ref: float
    a_ref: float
    c_ref: float
    max_iterations: int  # most k-iterations any root needed
    v: np.ndarray = field(default_factory=lambda: np.zeros(0))
    q: np.ndarray = field(default_factory=lambda: np.zeros(0))
    rho: np.ndarray = field(default_factory=lambda: np.zeros(0))
    g: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    gamma: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    omega: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    k_red: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    v_eas_m_s: float | None = None  # equivalent airspeed sqrt(2 q_f / rho_0) at the flutter point
    altitude_ref_m: float | None = None  # ISA altitude of rho_ref / a_ref (None: both given explicitly)
    v_eas: np.ndarray = field(default_factory=lambda: np.zeros(0))  # [nv] sqrt(2 q / rho_0)




def _aero_fn(aero: Any, m: int) -> AeroFn:
    """Vectorized H(k) [n, m, m] from an AeroTable or a callable of k [n] (checked on one value)."""
    if not callable(aero):
        raise InputError("aero", "must be an AeroTable or a callable k[n] -> H[n, m, m]")
    probe = np.asarray(aero(np.array([0.1 if not isinstance(aero, AeroTable) else aero.k[0]])), dtype=complex)
    if probe.shape != (1, m, m):
        raise InputError("aero", f"H(k) must have shape (n, {m}, {m}) for {m} structural modes, got {probe.shape}")
    return lambda k: np.asarray(aero(k), dtype=complex)


class _Pk:
    """p-k root iteration of all structural branches at one (V, q) (internal)."""

    def __init__(self, omega: np.ndarray, zeta: np.ndarray, h: AeroFn, b: float, k_tol: float, max_iter: int):
        self.omega, self.zeta, self.h, self.b = omega, zeta, h, b
        self.k_tol, self.max_iter = k_tol, max_iter
        self.n = omega.size
        self.iterations = 0

    def _eig_pick(self, v: float, q: float, kk: np.ndarray, p: np.ndarray, br: np.ndarray) -> np.ndarray:
        """Roots at reduced frequencies kk [nb] nearest the estimates p [nb] (Im p >= 0), one batched eigvals."""
        n = self.n
        a = np.zeros((br.size, 2 * n, 2 * n), complex)
        a[:, :n, n:] = np.eye(n)
        a[:, n:, n:] = -np.diag(2.0 * self.zeta * self.omega)
        a[:, n:, :n] = -np.diag(self.omega**2) + q * self.h(kk)
        lam = np.linalg.eigvals(a)  # [nb, 2n]
        cand = np.where(lam.imag >= -1e-9 * np.abs(lam), lam, np.nan)
        scale = np.maximum(np.abs(p), self.omega[br])[:, None]
        j = np.nanargmin(np.abs(cand - p[:, None]) / scale, axis=1)
        return lam[np.arange(br.size), j]

    def roots(self, v: float, q: float, p0: np.ndarray, branches: np.ndarray | None = None) -> np.ndarray:
        """Converged p [len(branches)] (rad/s) of the given branches at speed v (m/s) and q (Pa), from guesses p0.

        Direct substitution k <- Im(p) b / V; a branch still unconverged after 30 iterations is checked at
        k = 0 (a real root there is a converged non-oscillatory root: the substitution creeps towards k = 0
        only linearly) and then solved as the scalar fixed point by brentq on Im(p(k)) b / V - k.
        """
        br = np.arange(self.n) if branches is None else np.asarray(branches)
        p = np.asarray(p0, dtype=complex).copy()
        kk = np.abs(p.imag) * self.b / v
        done = np.zeros(br.size, bool)
        for it in range(1, 31):  # direct substitution (converges in ~10-20 iterations when it does)
            idx = np.nonzero(~done)[0]
            p_new = self._eig_pick(v, q, kk[idx], p[idx], br[idx])
            k_new = np.abs(p_new.imag) * self.b / v
            conv = np.abs(k_new - kk[idx]) <= self.k_tol * (1.0 + kk[idx])
            p[idx], kk[idx] = p_new, k_new
            done[idx] = conv
            if done.all():
                self.iterations = max(self.iterations, it)
                return p
        self.iterations = max(self.iterations, 30)
        for i in np.nonzero(~done)[0]:  # the few stubborn branches, one scalar problem each
            pb = br[i : i + 1]
            p_zero = self._eig_pick(v, q, np.zeros(1), p[i : i + 1], pb)[0]
            if abs(p_zero.imag) <= 1e-9 * max(abs(p_zero), 1.0):
                p[i] = p_zero.real
                continue

            def resid(k: float, i: int = int(i), pb: np.ndarray = pb) -> float:
                pk_ = self._eig_pick(v, q, np.array([k]), p[i : i + 1], pb)[0]
                return abs(pk_.imag) * self.b / v - k

            hi = max(2.0 * kk[i], 1e-3)
            for _ in range(self.max_iter):  # bracket by doubling
                if resid(hi) < 0:
                    break
                hi *= 2.0
            else:
                raise RuntimeError(f"p-k iteration did not converge at V = {v:.6g} m/s, q = {q:.6g} Pa "
                                   f"(branch {int(br[i]) + 1}, k = {kk[i]:.6g})")
            k_root = brentq(resid, 0.0, hi, xtol=self.k_tol)
            p[i] = self._eig_pick(v, q, np.array([k_root]), p[i : i + 1], pb)[0]
        return p


def pk_flutter(
    omega: np.ndarray,
    aero: Any,
    c_ref: float,
    mach: float,
    *,
    sweep: str = "constant-speed",
    zeta: np.ndarray | float | None = None,
    altitude_ref_m: float = DEFAULT_ALTITUDE_REF_M,
    rho_ref: float | None = None,
    a_ref: float | None = None,
    v_max: float | None = None,
    q_max: float | None = None,
    altitude_range_m: tuple[float, float] = (0.0, 20_000.0),
    n_points: int = 40,
    rtol: float = 1e-4,
    k_tol: float = 1e-9,
    max_iter: int = 200,
    max_jump: float = 0.15,
) -> PkResult:
    """p-k flutter search at one Mach for structure ``omega`` [k] (rad/s) and harmonic aerodynamics ``aero``.

    ``aero``: an AeroTable or a callable k [n] -> H [n, k, k] (m^3, f = H xi per unit q); ``c_ref`` (m) sets
    b = c_ref / 2. Reference state, ranges and sweeps as ``flutter.flutter_analysis`` (rho_ref, a_ref from ISA
    at ``altitude_ref_m``; v_max default 3 M a_ref; q_max default 4 x 0.5 rho_ref (M a_ref)^2). ``n_points``
    coarse sweep points; a step where a root moves by more than ``max_jump`` x max(|p|, omega_j) is split
    (up to 1/64). The first gamma = 0 crossing is refined with brentq to ``rtol`` relative in the sweep
    parameter. Returns a PkResult (no flutter in range: flutter_found False).
    """
    if sweep not in SWEEPS:
        raise InputError("sweep", f"must be one of {SWEEPS}, got {sweep!r}")
    om, zt, c_ref, mach = check_flutter_inputs(omega, zeta, c_ref, mach, sweep)
    n = om.size
    if not (isinstance(n_points, int | np.integer) and 4 <= n_points <= 5000):
        raise InputError("n_points", f"must be an integer in [4, 5000], got {n_points!r}")
    rtol = finite_positive("rtol", rtol)
    h = _aero_fn(aero, n)
    rho_ref, a_ref, h_ref = resolve_reference(altitude_ref_m, rho_ref, a_ref)
    # sweep parameter s -> (V, rho) (the flutter search's sweeps); s = s0 is q = 0, where the branches start at
    # the in-vacuo poles
    sw = make_sweep(sweep, mach, om, c_ref, rho_ref, a_ref, v_max, q_max, altitude_range_m)
    s0, grid = sw.p_start, sw.grid(int(n_points))

    def cond(s: float) -> tuple[float, float]:
        v, rho = sw.cond(np.array([s]))
        return float(v[0]), float(rho[0])

    b = 0.5 * c_ref
    pk = _Pk(om, zt, h, b, float(k_tol), int(max_iter))
    p_vac = om * (-zt + 1j * np.sqrt(1.0 - zt**2))

    def solve(s: float, p_guess: np.ndarray, branches: np.ndarray | None = None) -> np.ndarray:
        v, rho = cond(s)
        return pk.roots(v, 0.5 * rho * v**2, p_guess, branches)

    def step(s_a: float, p_a: np.ndarray, p_prev: np.ndarray | None, s_prev: float | None, s_b: float,
             depth: int = 0) -> np.ndarray:
        """Roots at s_b continued from s_a (linear predictor from the point before when known)."""
        ratio = 0.0 if p_prev is None or s_prev is None else (s_b - s_a) / (s_a - s_prev)
        guess = p_a + (p_a - p_prev) * ratio if 0.0 < ratio <= 2.0 else p_a  # no long-range extrapolation
        p_b = solve(s_b, guess)
        jump = np.abs(p_b - p_a) / np.maximum(np.abs(p_a), om)
        if np.any(jump > max_jump) and depth < 6:
            s_m = 0.5 * (s_a + s_b)
            p_m = step(s_a, p_a, p_prev, s_prev, s_m, depth + 1)
            return step(s_m, p_m, p_a, s_a, s_b, depth + 1)
        return p_b

    # q -> 0 limit of the first step: start from the in-vacuo poles, no predictor
    path = np.empty((grid.size, n), complex)
    p_a, p_prev, s_a, s_prev = p_vac, None, s0, None
    for i, s in enumerate(grid):  # the coarse sweep (tens of points)
        p_b = step(s_a, p_a, p_prev, s_prev, float(s))
        path[i] = p_b
        p_prev, s_prev, p_a, s_a = p_a, s_a, p_b, float(s)

    real_root = np.abs(path.imag) <= 1e-9 * np.abs(path)
    with np.errstate(divide="ignore", invalid="ignore"):
        gamma = np.where(real_root, np.sign(path.real) * np.inf, path.real / np.abs(path.imag))
    g_path = 2.0 * path.real / np.abs(path)
    vq = [cond(float(s)) for s in grid]
    v_g = np.array([x[0] for x in vq])
    rho_g = np.array([x[1] for x in vq])
    q_g = 0.5 * rho_g * v_g**2
    keep = grid >= 0.0
    v_axis = sw.speed_axis(v_g, q_g)
    common: dict[str, Any] = dict(
        rho_ref=rho_ref, a_ref=a_ref, c_ref=c_ref, altitude_ref_m=h_ref, v=v_axis[keep], v_eas=eas(q_g)[keep],
        q=q_g[keep], rho=rho_g[keep],
        g=g_path[keep], gamma=gamma[keep], omega=np.abs(path.imag[keep]),
        k_red=np.abs(path.imag[keep]) * b / v_g[keep, None],
    )
    unstable = path.real > 1e-12 * np.abs(path)
    first = np.where(unstable.any(axis=0), unstable.argmax(axis=0), grid.size)
    i_cross = int(first.min())
    none: dict[str, Any] = dict(v_flutter_m_s=None, omega_flutter_rad_s=None, q_flutter_pa=None, rho_flutter=None,
                                k_flutter=None, v_true_m_s=None, v_eas_m_s=None, flutter_mode=None)
    if i_cross >= grid.size:
        return PkResult(mach=mach, sweep=sweep, flutter_found=False, message="no flutter in the sweep range",
                        max_iterations=pk.iterations, **none, **common)
    message = ""
    if i_cross == 0:  # bracket from just after q = 0 (at q = 0 an undamped branch has Re p = 0 exactly)
        lo_s = s0 + 1e-6 * (float(grid[0]) - s0)
        lo_p = solve(lo_s, p_vac)
    else:
        lo_s, lo_p = float(grid[i_cross - 1]), path[i_cross - 1]
    hi_s, hi_p = float(grid[i_cross]), path[i_cross]

    def re_at(s: float, j: int) -> float:
        """Re(p) of branch j at s, iterated from the linear interpolation of the bracket ends."""
        if s == lo_s:
            return float(lo_p[j].real)
        if s == hi_s:
            return float(hi_p[j].real)
        t = (s - lo_s) / (hi_s - lo_s)
        return float(solve(s, np.array([lo_p[j] + t * (hi_p[j] - lo_p[j])]), np.array([j]))[0].real)

    s_f, branch = math.inf, -1
    scale = max(abs(hi_s), abs(lo_s), 1e-300)
    for j in np.nonzero(first == i_cross)[0]:  # branches first unstable in this interval (a few)
        if lo_p[j].real > 0:
            sj = lo_s
        else:
            sj = brentq(re_at, lo_s, hi_s, args=(int(j),), xtol=1e-3 * rtol * scale, rtol=max(rtol * 1e-2, 1e-14))
        if sj < s_f:
            s_f, branch = sj, int(j)
    if s_f == lo_s and i_cross == 0:
        message = "structural branch unstable from the start of the sweep; "
    t = (s_f - lo_s) / (hi_s - lo_s)
    p_f = complex(solve(s_f, np.array([lo_p[branch] + t * (hi_p[branch] - lo_p[branch])]),
                        np.array([branch]))[0]) if 0 < t < 1 else complex((lo_p if t <= 0 else hi_p)[branch])
    v_f, rho_f = cond(s_f)
    q_f = 0.5 * rho_f * v_f**2
    omega_f = abs(p_f.imag)
    if omega_f <= 1e-6 * float(om.max()):
        message += "zero-frequency crossing (static divergence); "
    v_eas_f = float(eas(np.array(q_f)))
    message += (f"p-k flutter on structural branch {branch + 1} at q = {q_f:.6g} Pa, true airspeed V = {v_f:.6g} "
                f"m/s (EAS {v_eas_f:.6g} m/s), omega = {omega_f:.6g} rad/s ({sweep})")
    return PkResult(
        mach=mach, sweep=sweep, flutter_found=True, v_flutter_m_s=v_f, v_eas_m_s=v_eas_f, omega_flutter_rad_s=omega_f,
        q_flutter_pa=q_f, rho_flutter=rho_f, k_flutter=omega_f * b / v_f, v_true_m_s=v_f,
        flutter_mode=branch + 1, message=message, max_iterations=pk.iterations, **common,
    )
