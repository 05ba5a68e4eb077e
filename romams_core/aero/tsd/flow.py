"""Time marching of the TSD equation: the approximate-factorization Newton step, the wake, steady and unsteady runs.

Lengths are in root chords, time in t* = t U / c_ref, the potential in U c_ref (so phi_x is u / U).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from romams_core.aero.tsd import kernels
from romams_core.aero.tsd.coefficients import TsdCoefficients
from romams_core.aero.tsd.grid import TsdGrid

#: backward-difference coefficients (phi_tt: a0..a3, phi_t: b0..b2) of the first- and second-order schemes
TIME_SCHEMES = {0: ((1.0, -1.0, 0.0, 0.0), (0.0, 0.0, 0.0)), 1: ((1.0, -2.0, 1.0, 0.0), (1.0, -1.0, 0.0)),
                2: ((2.0, -5.0, 4.0, -1.0), (1.5, -2.0, 0.5))}
#: cap of the upstream non-reflecting coefficient M / (1 - M), singular at M = 1
UPSTREAM_KAPPA_CAP = 20.0


@dataclass
class SteadyResult:
    """Outcome of a pseudo-time steady solution: residual history (max |N| per step) and convergence."""

    steps: int
    converged: bool
    residual_history: np.ndarray
    dphi_history: np.ndarray
    seconds: float


@dataclass
class TsdFlow:
    """State of one TSD flow on a grid: four time levels of phi, the surface slopes and the wake jump."""

    grid: TsdGrid
    coef: TsdCoefficients
    phi: np.ndarray = field(init=False)
    levels: list[np.ndarray] = field(init=False)  # phi at n, n-1, n-2
    w_up: np.ndarray = field(init=False)  # [ni, nj] phi_z at z = 0+ on the planform
    w_lo: np.ndarray = field(init=False)  # [ni, nj] phi_z at z = 0- on the planform
    gamma: np.ndarray = field(init=False)  # [ni, nj] potential jump on the wake sheet
    t: float = 0.0
    _gamma_hist: list[np.ndarray] = field(init=False, default_factory=list)
    _t_hist: list[float] = field(init=False, default_factory=list)

    def __post_init__(self) -> None:
        g = self.grid
        ni, nj, nk = g.shape
        self.phi = np.zeros(g.shape)
        self.levels = [self.phi.copy(), self.phi.copy(), self.phi.copy()]
        self.w_up = np.zeros((ni, nj))
        self.w_lo = np.zeros((ni, nj))
        self.gamma = np.zeros((ni, nj))
        self._co = np.array([self.coef.A, self.coef.B, self.coef.E, self.coef.F, self.coef.G, self.coef.H,
                             self.coef.u_star])
        self._cj = g.chord(g.yc)
        self._cyf = g.chord(g.yf[1:-1]) if nj > 1 else np.ones(1)
        self._xiy_xf = g.xi_y(g.xf[1:-1][:, None], g.yc[None, :]) if nj > 1 else np.zeros((ni - 1, 1))
        self._xiy_yf = g.xi_y(g.xc[:, None], g.yf[1:-1][None, :]) if nj > 1 else np.zeros((ni, 1))
        self._wing = g.wing
        self._wake = g.wake
        self._i_te = int(np.flatnonzero(g.xc < 1.0)[-1])
        self._wake_delay = np.where(self._wake, self._cj[None, :] * (g.xc[:, None] - 1.0), 0.0)  # t* lag
        m = self.coef.mach
        self._kappa = (-min(m / (1.0 - m), UPSTREAM_KAPPA_CAP), m / (1.0 + m), m, m)
        self._rhs = np.zeros(g.shape)

    # ----- wake -------------------------------------------------------------------------------------------------
    def gamma_te(self, phi: np.ndarray | None = None) -> np.ndarray:
        """[nj] potential jump at the trailing edge, from the last wing node extrapolated to z = 0+ and 0-."""
        phi = self.phi if phi is None else phi
        k0, zc, i = self.grid.k0, self.grid.zc, self._i_te
        upper = phi[i, :, k0 + 1] - self.w_up[i] * zc[k0 + 1]
        lower = phi[i, :, k0] - self.w_lo[i] * zc[k0]
        return np.where(self.grid.yc < self.grid.semispan, upper - lower, 0.0)

    def _update_gamma(self, steady: bool) -> None:
        """Wake jump: the trailing-edge jump convected at the free-stream speed (exactly, from its history)."""
        gte = self.gamma_te()
        if steady:  # pseudo-time: the jump is updated once per relaxation cycle (solve_steady)
            return
        if not self._t_hist:
            self.gamma = np.where(self._wake, gte[None, :], 0.0)
            return
        t_hist = np.asarray(self._t_hist + [self.t])
        g_hist = np.vstack(self._gamma_hist + [gte])  # [nt, nj]
        tau = np.clip(self.t - self._wake_delay, t_hist[0], self.t)
        pos = np.interp(tau, t_hist, np.arange(t_hist.size))
        lo = np.floor(pos).astype(int)
        hi = np.minimum(lo + 1, t_hist.size - 1)
        w = pos - lo
        jj = np.broadcast_to(np.arange(self.grid.shape[1])[None, :], lo.shape)
        val = (1.0 - w) * g_hist[lo, jj] + w * g_hist[hi, jj]
        self.gamma = np.where(self._wake, val, 0.0)

    # ----- one factored Newton step -----------------------------------------------------------------------------
    def _tc(self, order: int, dt: float) -> np.ndarray:
        a, b = TIME_SCHEMES[order]
        return np.array([*a, *b, dt, *self._kappa])

    def newton_iteration(self, tc: np.ndarray, steady: bool) -> tuple[float, float, float]:
        """One residual evaluation and factored solve at the new time level; returns (max|N|, rms N, max|dphi|)."""
        g = self.grid
        self._update_gamma(steady)
        p1, p2, p3 = self.levels
        nmax, nrms = kernels.residual(self.phi, p1, p2, p3, tc, self._co, g.xc, g.xf, g.yc, g.yf, g.zc, g.zf,
                                      self._cj, self._cyf, self._xiy_xf, self._xiy_yf, self._wing, self._wake,
                                      self.w_up, self.w_lo, self.gamma, g.k0, g.lateral_far, self._rhs)
        w = self._rhs
        kernels.solve_xi(self.phi, w, tc, self._co, g.xc, g.xf, self._cj, self._xiy_xf)
        kernels.solve_eta(self.phi, w, tc, self._co, g.xc, g.yc, g.yf, self._cj, self._cyf, g.lateral_far)
        kernels.solve_zeta(w, tc, self._co, g.zc, g.zf, self._wing, g.k0)
        self.phi += w
        return float(nmax), float(nrms), float(np.max(np.abs(w)))

    def _shift(self) -> None:
        """Make room for a new time level (phi becomes level n; the guess is a linear extrapolation)."""
        p1, p2, p3 = self.levels
        p3[...] = p2
        p2[...] = p1
        p1[...] = self.phi

    # ----- runs -------------------------------------------------------------------------------------------------
    def solve_steady(self, s_range: tuple[float, float] = (1e-4, 10.0), n_cycle: int = 8, max_cycles: int = 400,
                     tol: float = 1e-7, check: Callable[[int, float, float], None] | None = None) -> SteadyResult:
        """Steady flow by approximate-factorization (ADI) relaxation in pseudo-time; returns the residual history.

        The pseudo-time step cycles geometrically through ``n_cycle`` values of s = dt^2 / (A c) in ``s_range`` (the
        AF2 practice of damping all error wavelengths); the wake jump takes the trailing-edge jump at the end of
        each cycle (updating it every step is unstable). Converged when max|dphi| over a cycle < tol.
        ``check(cycle, max|N|, max|dphi|)`` is called once per cycle (progress reporting; it may raise to cancel).
        """
        t0 = time.perf_counter()
        s_values = np.geomspace(s_range[0], s_range[1], n_cycle)
        res, dphis = [], []
        converged = False
        for cycle in range(1, max_cycles + 1):
            dcycle = nmax = 0.0
            for sv in s_values:
                self._shift()
                nmax, _, dmax = self.newton_iteration(self._tc(0, math.sqrt(sv * self.coef.A)), steady=True)
                dcycle = max(dcycle, dmax)
            self.gamma = np.where(self._wake, self.gamma_te()[None, :], 0.0)
            res.append(nmax)
            dphis.append(dcycle)
            if check is not None:
                check(cycle, nmax, dcycle)
            if not math.isfinite(dcycle):
                break
            if dcycle < tol:
                converged = True
                break
        self.start_unsteady()
        return SteadyResult(steps=len(res) * n_cycle, converged=converged, residual_history=np.asarray(res),
                            dphi_history=np.asarray(dphis), seconds=time.perf_counter() - t0)

    def start_unsteady(self) -> None:
        """Begin a time-accurate run from the current (converged) field at t* = 0."""
        for lev in self.levels:
            lev[...] = self.phi
        self.t = 0.0
        self._t_hist = [0.0]
        self._gamma_hist = [self.gamma_te()]

    def step(self, dt: float, n_sub: int = 2) -> tuple[float, float]:
        """Advance one time step dt (t*) with n_sub Newton sub-iterations; returns (max|N| last, max|dphi| last)."""
        self._shift()
        p1, p2 = self.levels[0], self.levels[1]
        self.phi[...] = 2.0 * p1 - p2
        self.t += dt
        tc = self._tc(2, dt)
        nmax = dmax = 0.0
        for _ in range(max(1, n_sub)):
            nmax, _, dmax = self.newton_iteration(tc, steady=False)
        self._t_hist.append(self.t)
        self._gamma_hist.append(self.gamma_te())
        return nmax, dmax

    # ----- surface quantities -----------------------------------------------------------------------------------
    def surface_cp(self, dt: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Linear Cp = -2 (phi_x + phi_t) [ni, nj] on the upper and lower surface nodes (steady if dt is None)."""
        g = self.grid
        k0 = g.k0
        out = []
        for k in (k0 + 1, k0):
            layer = self.phi[:, :, k]
            px = np.gradient(layer, g.xc, axis=0) / self._cj[None, :]
            cp = -2.0 * px
            if dt is not None:
                b0, b1, b2 = TIME_SCHEMES[2][1]
                pt = (b0 * layer + b1 * self.levels[0][:, :, k] + b2 * self.levels[1][:, :, k]) / dt
                cp = cp - 2.0 * pt
            out.append(np.where(self._wing, cp, np.nan))
        return out[0], out[1]

    def lifting_cp(self, dt: float | None = None) -> np.ndarray:
        """Delta Cp = Cp_lower - Cp_upper [ni, nj] on the planform (zero elsewhere), positive for lift."""
        up, lo = self.surface_cp(dt)
        return np.nan_to_num(lo - up)
