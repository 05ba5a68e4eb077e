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
from romams_core.aero.tsd.far_field import WakeFarField
from romams_core.aero.tsd.grid import TsdGrid
from romams_core.errors import InputError

#: backward-difference coefficients (phi_tt: a0..a3, phi_t: b0..b2) of the first- and second-order schemes
TIME_SCHEMES = {1: ((1.0, -2.0, 1.0, 0.0), (1.0, -1.0, 0.0)), 2: ((2.0, -5.0, 4.0, -1.0), (1.5, -2.0, 0.5))}
#: the outer-face conditions of a 3-D grid (``TsdFlow.far_field``)
FAR_FIELDS = ("plain", "wake")
#: cap of the upstream non-reflecting coefficient M / (1 - M), singular at M = 1
UPSTREAM_KAPPA_CAP = 20.0


def check_far_field(value: str) -> str:
    """``value`` if it names an outer-face condition of FAR_FIELDS, else InputError naming far_field."""
    if value not in FAR_FIELDS:
        raise InputError("far_field", f"must be one of {FAR_FIELDS}, got {value!r}")
    return value


def sponge_layer(grid: TsdGrid, rate: float, fraction: float = 0.5) -> np.ndarray:
    """[ni, nj, nk] damping rate of an absorbing layer in the outer ``fraction`` of each far-field extent.

    The first-order non-reflecting conditions reflect oblique waves; measured on the cropped delta (M 0.87,
    8 basis shapes), the ARX validation error fell from 3-5 % to 1.2-2.5 % when the boundaries were moved twice
    as far. The layer damps outgoing waves instead (rate * depth^2, depth 0..1 into the layer); it acts on
    phi_t only, so steady solutions are unchanged.
    """
    def depth(x: np.ndarray, inner: float, outer: float) -> np.ndarray:
        return np.clip((x - inner) / (outer - inner), 0.0, 1.0)

    xf, zf = grid.xf, grid.zf
    up = depth(-grid.xc, -xf[0] * (1 - fraction), -xf[0])
    down = depth(grid.xc, 1.0 + (xf[-1] - 1.0) * (1 - fraction), xf[-1])
    rx = np.maximum(up, down)
    rz = np.maximum(depth(grid.zc, zf[-1] * (1 - fraction), zf[-1]), depth(-grid.zc, -zf[0] * (1 - fraction), -zf[0]))
    if grid.lateral_far:
        b, ymax = grid.semispan, grid.yf[-1]
        ry = depth(grid.yc, b + (ymax - b) * (1 - fraction), ymax)
        if grid.root == "open":  # a free wing's lateral far field below the root
            ry = np.maximum(ry, depth(-grid.yc, -grid.yf[0] * (1 - fraction), -grid.yf[0]))
    else:
        ry = np.zeros(grid.yc.size)
    r = np.maximum(np.maximum(rx[:, None, None], ry[None, :, None]), rz[None, None, :])
    return rate * r ** 2


@dataclass
class JumpHistory:
    """Trailing-edge jumps [n, nj] at times [n] (t*) in arrays that grow by doubling, with a spare row for the
    current iterate, so that the wake interpolation stacks nothing per sub-iteration."""

    nj: int
    t: np.ndarray = field(init=False)  # [capacity]
    g: np.ndarray = field(init=False)  # [capacity, nj]
    start: int = 0
    stop: int = 0

    def __post_init__(self) -> None:
        self.t = np.zeros(64)
        self.g = np.zeros((64, self.nj))

    def reset(self, t0: float, g0: np.ndarray) -> None:
        """Forget everything; the history starts with jump ``g0`` [nj] at ``t0`` (t*)."""
        self.start, self.stop = 0, 0
        self.append(t0, g0)

    def append(self, t: float, g: np.ndarray) -> None:
        """Add the jump ``g`` [nj] at time ``t`` (t*), after the last one."""
        if self.stop + 2 > self.t.size:  # keep the spare row: move the kept rows to the front, or double
            n = self.stop - self.start
            size = self.t.size if 2 * (n + 2) <= self.t.size else 2 * self.t.size
            t_new, g_new = np.zeros(size), np.zeros((size, self.nj))
            t_new[:n], g_new[:n] = self.t[self.start:self.stop], self.g[self.start:self.stop]
            self.t, self.g, self.start, self.stop = t_new, g_new, 0, n
        self.t[self.stop] = t
        self.g[self.stop] = g
        self.stop += 1

    def forget_before(self, t_min: float) -> None:
        """Drop the entries older than the last one at or before ``t_min`` (t*)."""
        old = int(np.searchsorted(self.t[self.start:self.stop], t_min, side="right")) - 1
        if old > 0:
            self.start += old

    @property
    def empty(self) -> bool:
        """True before the first entry (no run started)."""
        return self.stop == self.start

    def with_current(self, t: float, g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Views (times [n + 1], jumps [n + 1, nj]) of the history followed by the current iterate (``t``, ``g``)."""
        self.t[self.stop] = t
        self.g[self.stop] = g
        return self.t[self.start:self.stop + 1], self.g[self.start:self.stop + 1]


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
    sponge_rate: float = 1.0  # damping rate (1/t*) at the outer edge of the absorbing layer; 0: none
    #: the sheared frame's metric terms upwind in xi where the flow is supersonic (kernels: ``_span_flux``); False:
    #: central everywhere, the scheme until 2026-12-05, which does not converge with the span's cells at M 0.96
    cross_upwind: bool = True
    #: the outer faces of a 3-D grid: "wake" (the non-reflecting conditions plus the steady potential of the current
    #: circulation, ``far_field.WakeFarField``; the default since 2026-12-05) or "plain" (the non-reflecting
    #: conditions alone: slip walls in steady flow, whose images added 2-3 % to the steady GAF of AGARD 445.6)
    far_field: str = "wake"
    _hist: JumpHistory = field(init=False)  # empty until a run starts

    def __post_init__(self) -> None:
        g = self.grid
        ni, nj, nk = g.shape
        self.phi = np.zeros(g.shape)
        self.levels = [self.phi.copy(), self.phi.copy(), self.phi.copy()]
        self.w_up = np.zeros((ni, nj))
        self.w_lo = np.zeros((ni, nj))
        self.gamma = np.zeros((ni, nj))
        self._hist = JumpHistory(nj)
        self._co = np.array([self.coef.A, self.coef.B, self.coef.E, self.coef.F, self.coef.G, self.coef.H,
                             self.coef.u_star, 1.0 if self.cross_upwind else 0.0])
        self._cj = g.chord(g.yc)
        self._cyf = g.chord(g.yf[1:-1]) if nj > 1 else np.ones(1)
        self._c_root = float(g.chord(np.array(0.0)))  # chord at the root face (the antisymmetric root's flux)
        self._xiy_xf = g.xi_y(g.xf[1:-1][:, None], g.yc[None, :]) if nj > 1 else np.zeros((ni - 1, 1))
        self._xiy_yf = g.xi_y(g.xc[:, None], g.yf[1:-1][None, :]) if nj > 1 else np.zeros((ni, 1))
        self._wing = g.wing
        self._wake = g.wake
        self._i_te = int(np.flatnonzero(g.xc < 1.0)[-1])
        # t* lag of each wake node behind the last wing node, whose jump Gamma_TE is: no pressure jump from there on
        # (measuring it from the trailing edge put a pressure jump of about Gamma_t between the last wing node and the
        # first wake node, which does not shrink with the grid: +6 % lift on a plunging 2-D plate at k = 1,
        # docs/transonic.md 7.3)
        self._wake_delay = np.where(self._wake, self._cj[None, :] * (g.xc[:, None] - g.xc[self._i_te]), 0.0)
        self._max_delay = float(self._wake_delay.max(initial=0.0))
        m = self.coef.mach
        self._kappa = (-min(m / (1.0 - m), UPSTREAM_KAPPA_CAP), m / (1.0 + m), m, m)
        self._rhs = np.zeros(g.shape)
        self._far_u = np.zeros((2, nj, nk))
        self._far_w = np.zeros((2, ni, nj))
        self._far_v = np.zeros((2, ni, nk))
        check_far_field(self.far_field)
        self._wake_far = (WakeFarField.of(g, self._beta()) if self.far_field == "wake" and g.lateral_far
                          else None)
        #: 2-D only: the outer faces see the compressible vortex of the current circulation (steady far field)
        self.vortex_far_field = not g.lateral_far and nj == 1
        self.sponge = sponge_layer(g, self.sponge_rate) if self.sponge_rate > 0 else np.zeros(g.shape)

    # ----- wake -------------------------------------------------------------------------------------------------
    def gamma_te(self, phi: np.ndarray | None = None) -> np.ndarray:
        """[nj] potential jump at the trailing edge, from the last wing node extrapolated to z = 0+ and 0-."""
        phi = self.phi if phi is None else phi
        k0, zc, i = self.grid.k0, self.grid.zc, self._i_te
        upper = phi[i, :, k0 + 1] - self.w_up[i] * zc[k0 + 1]
        lower = phi[i, :, k0] - self.w_lo[i] * zc[k0]
        return np.where(self.grid.strips, upper - lower, 0.0)

    def _beta(self) -> float:
        """The far field's Prandtl-Glauert factor sqrt(E) (E = 1 - M^2 in every coefficient set)."""
        return math.sqrt(max(self.coef.E, 1e-6))

    def _vortex_far_field(self, circulation: float) -> None:
        """Far-field phi_x / phi_z on the outer faces of a 2-D grid from the compressible vortex at x = c/4.

        phi_v = circulation / (2 pi) * atan2(beta z, -(x - 1/4)) solves beta^2 phi_xx + phi_zz = 0 and jumps by the
        circulation across the wake (z = 0, x > 1/4), so the outer boundaries need not be far for a lifting airfoil.
        """
        g = self.grid
        beta = self._beta()
        k_ = circulation / (2.0 * math.pi)

        def grads(x: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            xx = x - 0.25
            r2 = xx * xx + (beta * z) ** 2
            return k_ * beta * z / r2, -k_ * beta * xx / r2

        for side, x in ((0, g.xf[0]), (1, g.xf[-1])):
            self._far_u[side, 0, :] = grads(np.full(g.zc.size, x), g.zc)[0]
        for side, z in ((0, g.zf[0]), (1, g.zf[-1])):
            self._far_w[side, :, 0] = grads(g.xc, np.full(g.xc.size, z))[1]

    def _update_gamma(self) -> None:
        """Wake jump: the trailing-edge jump convected at the free-stream speed (exactly, from its history)."""
        gte = self.gamma_te()
        if self.vortex_far_field:
            self._vortex_far_field(float(gte[0]))
        if self._wake_far is not None:
            self._wake_far.update(gte, self._far_u, self._far_w, self._far_v)
        if self._hist.empty:
            self.gamma = np.where(self._wake, gte[None, :], 0.0)
            return
        # the new time level's trailing-edge jump comes from the latest iterate (refreshed every sub-iteration)
        t_hist, g_hist = self._hist.with_current(self.t, gte)  # [nt], [nt, nj]
        tau = np.clip(self.t - self._wake_delay, t_hist[0], self.t)
        pos = np.interp(tau, t_hist, np.arange(t_hist.size))
        lo = np.floor(pos).astype(int)
        hi = np.minimum(lo + 1, t_hist.size - 1)
        w = pos - lo
        jj = np.broadcast_to(np.arange(self.grid.shape[1])[None, :], lo.shape)
        val = (1.0 - w) * g_hist[lo, jj] + w * g_hist[hi, jj]
        self.gamma = np.where(self._wake, val, 0.0)

    def _record_gamma(self) -> None:
        """Append the trailing-edge jump of the finished step; forget the history no wake node can still see.

        Without the trim every sub-iteration would interpolate in the whole run (a list re-stacked per
        sub-iteration was 10x slower per step after 15000 steps). The entries kept reach back at least the longest
        wake delay, so the interpolation in ``_update_gamma`` is unchanged.
        """
        self._hist.append(self.t, self.gamma_te())
        self._hist.forget_before(self.t - self._max_delay)

    # ----- one factored Newton step -----------------------------------------------------------------------------
    def _tc(self, order: int, dt: float) -> np.ndarray:
        a, b = TIME_SCHEMES[order]
        return np.array([*a, *b, dt, *self._kappa])

    def residual(self, tc: np.ndarray, phi: np.ndarray | None = None, out: np.ndarray | None = None
                 ) -> tuple[float, float]:
        """Fill ``out`` (default the step's right-hand side) with s N(phi) (default the current phi) about the time
        levels held; returns (max|N|, rms N) (kernels.residual)."""
        g = self.grid
        p1, p2, p3 = self.levels
        nmax, nrms = kernels.residual(self.phi if phi is None else phi, p1, p2, p3, tc, self._co, g.xc, g.xf, g.yc,
                                      g.yf, g.zc, g.zf, self._cj, self._cyf, self._xiy_xf, self._xiy_yf, self._wing,
                                      self._wake, self.w_up, self.w_lo, self.gamma, g.k0, g.lateral_far,
                                      g.root_code, self._c_root, self._far_u, self._far_w, self._far_v, self.sponge,
                                      self._rhs if out is None else out)
        return float(nmax), float(nrms)

    def newton_iteration(self, tc: np.ndarray) -> tuple[float, float, float]:
        """One residual evaluation and factored solve at the new time level; returns (max|N|, rms N, max|dphi|)."""
        g = self.grid
        self._update_gamma()
        nmax, nrms = self.residual(tc)
        w = self._rhs
        kernels.solve_xi(self.phi, w, tc, self._co, g.xc, g.xf, self._cj, self._xiy_xf, self.sponge)
        kernels.solve_eta(self.phi, w, tc, self._co, g.xc, g.yc, g.yf, self._cj, self._cyf, g.lateral_far,
                          g.root_code, self._c_root)
        kernels.solve_zeta(w, tc, self._co, g.zc, g.zf, self._wing, g.k0)
        self.phi += w
        return nmax, nrms, float(np.max(np.abs(w)))

    def _shift(self) -> None:
        """Make room for a new time level: phi becomes level n (the oldest level's array is reused for it)."""
        p1, p2, p3 = self.levels
        p3[...] = self.phi
        self.levels = [p3, p1, p2]

    # ----- runs -------------------------------------------------------------------------------------------------
    def solve_steady(self, dt: float = 0.02, max_steps: int = 4000, tol: float = 1e-6, n_sub: int = 2,
                     check: Callable[[int, float, float], None] | None = None) -> SteadyResult:
        """Steady flow by a time march with the time-accurate wake (first-order in time, which damps the start).

        Converged when the potential changes by less than ``tol`` per unit t* (max |dphi - mean dphi| / dt < tol):
        a uniform drift of phi carries no velocity and is left out, as a section with an open trailing edge (NACA
        4-digit) is a net source whose flux leaves through the non-reflecting far field as phi_t = const. The wake
        jump is convected from the trailing edge as in an unsteady run: relaxing it with large pseudo-time steps
        is unstable (the trailing-edge jump overshoots a sudden wake jump by up to 3x in an unconverged AF step).
        ``check(step, max|N|, change)`` is called every step (progress reporting; it may raise to cancel).
        """
        t0 = time.perf_counter()
        tc = self._tc(1, dt)
        res, dphis = [], []
        converged = False
        self.start_unsteady()
        for step in range(1, max_steps + 1):
            self._shift()
            self.t += dt
            nmax = dmax = 0.0
            for _ in range(max(1, n_sub)):
                nmax, _, dmax = self.newton_iteration(tc)
            self._record_gamma()
            dphi = self.phi - self.levels[0]
            change = float(np.max(np.abs(dphi - dphi.mean()))) / dt
            res.append(nmax)
            dphis.append(change)
            if check is not None:
                check(step, nmax, change)
            if not math.isfinite(change):
                break
            if change < tol:
                converged = True
                break
        self.start_unsteady()
        return SteadyResult(steps=len(res), converged=converged, residual_history=np.asarray(res),
                            dphi_history=np.asarray(dphis), seconds=time.perf_counter() - t0)

    def start_unsteady(self) -> None:
        """Begin a time-accurate run from the current (converged) field at t* = 0."""
        for lev in self.levels:
            lev[...] = self.phi
        self.t = 0.0
        self._hist.reset(0.0, self.gamma_te())

    def step(self, dt: float, n_sub: int = 2) -> tuple[float, float]:
        """Advance one time step dt (t*) with n_sub Newton sub-iterations; returns (max|N| last, max|dphi| last)."""
        self._shift()
        p1, p2 = self.levels[0], self.levels[1]
        np.multiply(p1, 2.0, out=self.phi)  # the guess: a linear extrapolation
        self.phi -= p2
        self.t += dt
        tc = self._tc(2, dt)
        nmax = dmax = 0.0
        for _ in range(max(1, n_sub)):
            nmax, _, dmax = self.newton_iteration(tc)
        self._record_gamma()
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

    def jump(self, phi: np.ndarray | None = None) -> np.ndarray:
        """[ni, nj] potential jump phi(0+) - phi(0-) at the planform nodes (extrapolated to the surface; 0 off it)."""
        phi = self.phi if phi is None else phi
        k0, zc = self.grid.k0, self.grid.zc
        jmp = (phi[:, :, k0 + 1] - self.w_up * zc[k0 + 1]) - (phi[:, :, k0] - self.w_lo * zc[k0])
        return np.where(self._wing, jmp, 0.0)

    def cell_lift(self, dt: float | None = None) -> np.ndarray:
        """[ni, nj] integral of Delta Cp over each planform cell's chord (c_ref units, per unit span).

        Delta Cp = 2 (J_x + J_t) with J the potential jump; the J_x part is integrated exactly as the difference
        of J between the cell faces (J = 0 at the leading edge), which resolves the square-root leading-edge
        singularity that a midpoint rule on Delta Cp misses (5 % of the lift of a 50-cell flat plate).
        """
        g = self.grid
        jmp = self.jump()
        xc = g.xc
        # face values: averages inside, 0 at the leading edge, linear extrapolation at the trailing edge
        jf = np.zeros((xc.size + 1, jmp.shape[1]))
        jf[1:-1] = 0.5 * (jmp[1:] + jmp[:-1])
        wing_i = np.flatnonzero((xc > 0) & (xc < 1))
        i0, i1 = wing_i[0], wing_i[-1]
        jf[i0] = 0.0
        slope = (jmp[i1] - jmp[i1 - 1]) / (xc[i1] - xc[i1 - 1])
        jf[i1 + 1] = jmp[i1] + slope * (g.xf[i1 + 1] - xc[i1])
        out = 2.0 * (jf[1:] - jf[:-1])
        if dt is not None:
            b0, b1, b2 = TIME_SCHEMES[2][1]
            jt = (b0 * jmp + b1 * self.jump(self.levels[0]) + b2 * self.jump(self.levels[1])) / dt
            out = out + 2.0 * jt * np.diff(g.xf)[:, None] * self._cj[None, :]
        return np.where(self._wing, out, 0.0)
