"""The transonic small-disturbance solver behind the time-domain ``UnsteadySolver`` protocol.

One ``simulate`` call: grid fitted to the planform, steady mean flow about the wing's thickness (pseudo-time
march, residual history kept), then the time-accurate run with every shape moving by its signal. The GAC are
the perturbation about the mean flow: f_i(t) = integral((dCp(t) - dCp_mean) h_i dS) (m^3), so a ROM identified
from them is linear about the transonic mean state (shock position and strength included).
"""

from __future__ import annotations

import copy
import math
import os
import threading
import time
from collections.abc import Callable
from concurrent.futures import FIRST_EXCEPTION, Future, ThreadPoolExecutor, wait
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np
import scipy.sparse as sp

from romams_core.aero.protocol import (
    Cancelled,
    ProgressFn,
    SolverInfo,
    check_dt_star,
    check_mach,
    check_shapes,
    check_signals,
    image_sign,
)
from romams_core.aero.tsd.coefficients import COEFFICIENT_SETS, tsd_coefficients
from romams_core.aero.tsd.flow import SteadyResult, TsdFlow, check_far_field
from romams_core.aero.tsd.grid import ROOT_OF_SYMMETRY, GridSpec, TsdGrid, wing_grid
from romams_core.errors import InputError
from romams_core.mesh import StandardMesh

#: thin-wing theory: thicker sections are refused
MAX_THICKNESS_TO_CHORD = 0.15
#: below this Mach the factored scheme needs ever more sub-iterations (the time terms scale with M^2): use the DLM
MIN_MACH = 0.4


#: the near-wake coupling is explicit: the stable step is about this many trailing-edge cells (root chords).
#: Re-measured with the wake delay from the last wing node (docs/transonic.md 7.5, ``benchmarks.tsd_step_cap``):
#: on the cropped delta a perturbed rest state decays at 3.72 cells (M 0.6 / 0.87 / 0.95, 60 t*) and grows at
#: 4.35 (M 0.87, 5 t*); step records at 3.72 and 2.90 cells agree to 0.01 % of the largest entry up to k 0.5
TE_CELLS_PER_STEP = 3.75
#: the time step (t*) in which ``TsdSolver.steady_steps`` counts the steady march's budget
STEADY_DT = 0.02
#: how often a run that diverged is repeated with the step halved (``TsdSolver.max_step_halvings``): the
#: trailing-edge cap is not a stability limit on every grid (the AGARD grid x 2 diverged at M 0.96 at 3.3 cells
#: within 2 t* and ran at half that step, docs/transonic.md 7.13)
MAX_STEP_HALVINGS = 2


class Diverged(RuntimeError):
    """A TSD march (steady or unsteady) whose field became non-finite: the step is too large for the grid.
    ``spent``: raised after the last halving allowed (no retry left)."""

    def __init__(self, message: str, spent: bool = False) -> None:
        super().__init__(message)
        self.spent = spent


def sub_iterations(mach: float) -> int:
    """Newton sub-iterations per step that keep the factored scheme stable at ``mach``.

    Measured on the AGARD 445.6 grid at dt 0.02: one grows at M 0.5, two are stable from M 0.5 up and grow at
    M 0.4, three are stable at 0.4. One sub-iteration at the cropped delta's capped step (0.0111) looked stable on
    2 modes but spoiled the 8-shape basis training at M 0.87 (ARX validation NRMSE 30 % against 4 % with two), so
    the count does not go below two.
    """
    return 3 if mach < 0.6 else 2


#: largest surface downwash |dh/dx + dh/dt| (U units, ~ rad) of a motion: beyond it small-disturbance theory is void
MAX_SURFACE_DOWNWASH = 0.5


#: wing columns of the TSD grid per shape, at least (a coarser grid cannot carry the shapes' slopes)
MIN_WING_COLUMNS_PER_SHAPE = 20


def check_thickness(form: str | None, t_c: float) -> tuple[str | None, float]:
    """Validate the aerodynamic thickness form (None: flat plate) and t/c (0 <= t/c <= 0.15)."""
    from romams_core.structure.modal import thickness_form  # validates the name

    if form is None or t_c == 0.0:
        return None, 0.0
    if not (isinstance(t_c, int | float) and math.isfinite(t_c) and 0.0 <= t_c <= MAX_THICKNESS_TO_CHORD):
        raise InputError("thickness_to_chord",
                         f"must be in [0, {MAX_THICKNESS_TO_CHORD}] for thin-wing (TSD) theory, got {t_c!r}")
    thickness_form(form, np.array([0.5]))
    return form, float(t_c)


def mesh_interpolation(mesh: StandardMesh, xi: np.ndarray, eta: np.ndarray) -> sp.csr_matrix:
    """Sparse [K, N] bilinear interpolation of standard-mesh nodal values at chord/span fractions xi, eta."""
    nc, ns = mesh.n_chord, mesh.n_span
    s = np.clip(np.asarray(xi, float), 0.0, 1.0) * nc
    t = np.interp(np.asarray(eta, float), mesh.eta, np.arange(ns + 1.0))  # node rows need not be equally spaced
    i = np.minimum(np.floor(s).astype(int), nc - 1)
    j = np.minimum(np.floor(t).astype(int), ns - 1)
    fs, ft = s - i, t - j
    n00 = j * (nc + 1) + i
    cols = np.column_stack([n00, n00 + 1, n00 + nc + 1, n00 + nc + 2]).ravel()
    w = np.column_stack([(1 - fs) * (1 - ft), fs * (1 - ft), (1 - fs) * ft, fs * ft]).ravel()
    rows = np.repeat(np.arange(s.size), 4)
    return sp.csr_matrix((w, (rows, cols)), shape=(s.size, mesh.n_nodes))


def substep_inputs(signals: np.ndarray, n_int: int, dt_star: float) -> tuple[np.ndarray, np.ndarray]:
    """Displacement and rate (per t*) of signals [T, m] at the n_int internal steps of each signal step, [T, n_int, m].

    Sample n is reached at the end of signal step n (u = 0 before the first). Inside step n the motion is the cubic
    through samples n-3 .. n (zero before the start), and the rate is that cubic's derivative: causal, 4th-order in
    the displacement, and the rate jumps at a sample only by O(dt_star^3). Holding the rate at (u_n - u_n-1) / dt_star
    over the step, as a linear interpolation does, lags every rate-driven load by half a signal step and samples the
    load right after each jump of the rate: on AGARD 445.6 at M 0.7, k 0.95 it put -10 deg on the bending GAF column
    and +5 %, -6 deg on the third mode's (docs/transonic.md 7.3).
    """
    n_t, m = signals.shape
    pad = np.concatenate([np.zeros((3, m)), signals], axis=0)  # pad[n + 3] = u_n
    tau = np.arange(1, n_int + 1) / n_int  # position in the step, 1 at sample n
    # Lagrange weights on the nodes -2, -1, 0, 1 (u_n-3 .. u_n), with tau measured from node 0 (u_n-1)
    w = np.stack([-(tau ** 3 - tau) / 6.0, (tau ** 3 + tau ** 2 - 2.0 * tau) / 2.0,
                  -(tau ** 3 + 2.0 * tau ** 2 - tau - 2.0) / 2.0, (tau ** 3 + 3.0 * tau ** 2 + 2.0 * tau) / 6.0])
    dw = np.stack([-(3.0 * tau ** 2 - 1.0) / 6.0, (3.0 * tau ** 2 + 2.0 * tau - 2.0) / 2.0,
                   -(3.0 * tau ** 2 + 4.0 * tau - 1.0) / 2.0, (3.0 * tau ** 2 + 6.0 * tau + 2.0) / 6.0]) / dt_star
    nodes = np.stack([pad[q: q + n_t] for q in range(4)])  # [4, T, m]: u_n-3 .. u_n for each step n
    return np.einsum("qs,qtm->tsm", w, nodes), np.einsum("qs,qtm->tsm", dw, nodes)


#: How each root symmetry is modelled (the solver's description).
_ROOT_WORDS = {
    "symmetric": "(symmetry plane: zero flux, the symmetric half wing)",
    "antisymmetric": "(antisymmetry plane: phi = 0 on it, the mirror image's potential of the opposite sign)",
    "none": "(a free wing: the grid continues below the root to a lateral far field)",
}


@dataclass
class MeanFlow:
    """Steady mean flow of one training run: surface Cp on the planform nodes and the convergence history."""

    mach: float
    x_over_c: np.ndarray  # [ni_wing] chord fractions of the wing nodes
    eta: np.ndarray  # [nj_wing] span fractions of the wing node columns
    cp_upper: np.ndarray  # [ni_wing, nj_wing]
    cp_lower: np.ndarray
    cp_star: float
    steady: SteadyResult
    dt: float = 0.02  # internal time step (t*)
    step_halvings: int = 0  # times the step was halved after a diverged run (``TsdSolver.max_step_halvings``)
    far_field: str = TsdFlow.far_field  # the outer faces it was solved with (absent in dicts before 2026-12-05)

    @property
    def cp_min(self) -> float:
        """Lowest surface Cp of either side; below ``cp_star`` the mean flow is supercritical."""
        return float(min(self.cp_upper.min(), self.cp_lower.min()))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (lists of floats)."""
        return {"mach": self.mach, "x_over_c": self.x_over_c.tolist(), "eta": self.eta.tolist(),
                "cp_upper": self.cp_upper.tolist(), "cp_lower": self.cp_lower.tolist(), "cp_star": self.cp_star,
                "steady_steps": self.steady.steps, "steady_converged": self.steady.converged, "dt": self.dt,
                "step_halvings": self.step_halvings, "far_field": self.far_field,
                "steady_seconds": self.steady.seconds,
                "residual_history": self.steady.residual_history[:: max(1, self.steady.steps // 200)].tolist()}


@dataclass
class TsdSolver:
    """Unsteady, nonlinear, conservative TSD solver (CAP-TSD family) on a sheared planform-fitted grid.

    ``thickness_form``/``thickness_to_chord``: the wing section (None: flat plate); ``dt``: the largest internal
    time step (t*), the signals' step is subdivided to meet it; ``n_sub``: Newton sub-iterations per step (None:
    ``sub_iterations(mach)``; the lagged cross-derivative and wake terms need them for stability, and a second
    changed the linear GAF by < 0.1 %). The kernels are serial: numba's parallel loops ran 12x slower with the
    cores oversubscribed and abort in forked training processes. ``symmetry``: the root's, as the DLM's
    (symmetric: the root face is a symmetry plane; antisymmetric: an antisymmetry plane, phi = 0 on it; none: a
    free wing, the grid continues below the root to a lateral far field of its own).
    """

    thickness_form: str | None = None
    thickness_to_chord: float = 0.0
    grid: GridSpec = field(default_factory=GridSpec)
    dt: float = 0.02
    n_sub: int | None = None
    sponge_rate: float = 1.0
    coefficients: str = "ames"
    steady_steps: int = 2500  # the steady march's budget in steps of STEADY_DT (50 t*), whatever dt is
    steady_tol: float = 2e-4
    name: str = "tsd"
    record_threads: int | None = None
    symmetry: str = "symmetric"  # of the root plane: symmetric, antisymmetric or none (a free wing)
    te_cells_per_step: float = TE_CELLS_PER_STEP  # the step cap in trailing-edge cells (``time_step``)
    max_step_halvings: int = MAX_STEP_HALVINGS  # retries of a diverged run, each at half the step
    cross_upwind: bool = True  # the sweep's metric terms upwind at supersonic points (``TsdFlow.cross_upwind``)
    far_field: str = TsdFlow.far_field  # the 3-D outer faces (``TsdFlow.far_field``): "wake" or "plain" (slip walls)
    last_mean_flow: MeanFlow | None = field(default=None, init=False, repr=False)
    step_halvings: int = field(default=0, init=False)  # halvings this solver needed so far (kept for later runs)
    #: the last converged steady state (key, flow, summary): a training, its step records and a linearity check
    #: each start from it, so it is marched once per (planform, Mach, settings, step)
    _steady: tuple[tuple[Any, ...], TsdFlow, MeanFlow] | None = field(default=None, init=False, repr=False,
                                                                        compare=False)

    def __post_init__(self) -> None:
        self.thickness_form, self.thickness_to_chord = check_thickness(self.thickness_form,
                                                                       self.thickness_to_chord)
        if self.coefficients not in COEFFICIENT_SETS:
            raise InputError("coefficients", f"must be one of {COEFFICIENT_SETS}, got {self.coefficients!r}")
        if not (math.isfinite(self.dt) and 0.0 < self.dt <= 0.2):
            raise InputError("dt", f"must be in (0, 0.2] (t* units), got {self.dt!r}")
        image_sign(self.symmetry)  # InputError naming symmetry
        check_far_field(self.far_field)
        if not (isinstance(self.max_step_halvings, int) and 0 <= self.max_step_halvings <= 6):
            raise InputError("max_step_halvings", f"must be an integer in [0, 6], got {self.max_step_halvings!r}")

    def info(self, mach: float) -> SolverInfo:
        """Describe the solver and its caveats at ``mach``."""
        warnings = []
        if mach >= 0.98:
            warnings.append(f"M = {mach:.3f}: near-sonic free stream, the upstream far-field condition is capped")
        return SolverInfo(name="tsd", description=(
            "unsteady nonlinear transonic small-disturbance potential (CAP-TSD family: approximate factorization, "
            f"Engquist-Osher differencing, thin-wing boundary conditions; coefficients '{self.coefficients}', "
            f"isentropic and inviscid), root {self.symmetry} {_ROOT_WORDS[self.symmetry]}"), warnings=warnings)

    # ----- set-up -----------------------------------------------------------------------------------------------
    def build_grid(self, mesh: StandardMesh) -> TsdGrid:
        """Sheared grid of the mesh's planform (root chord units) with the root condition of ``symmetry``."""
        pf = mesh.planform
        kinks = np.reshape(np.asarray(pf.kinks, dtype=float), (-1, 3)) / pf.c_ref
        return wing_grid(pf.semispan / pf.c_ref, pf.tip_chord / pf.root_chord, math.tan(pf.sweep_le), self.grid,
                         kinks, root=ROOT_OF_SYMMETRY[self.symmetry])

    def _thickness_slope(self, grid: TsdGrid) -> np.ndarray:
        """[ni] half-thickness slope d(tau)/dx on the wing nodes (cell averages; zero off the chord)."""
        if self.thickness_form is None:
            return np.zeros(grid.xc.size)
        from romams_core.structure.modal import thickness_form

        tform = thickness_form(self.thickness_form, np.clip(grid.xf, 0.0, 1.0))
        slope = 0.5 * self.thickness_to_chord * np.diff(tform) / np.diff(grid.xf)
        return np.where((grid.xc > 0) & (grid.xc < 1), slope, 0.0)

    def _shape_operators(self, mesh: StandardMesh, grid: TsdGrid, shapes: np.ndarray
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Shape values h/c_ref and slopes dh/dx on the wing nodes, each [n_wing, m], and the node mask."""
        wing = grid.wing
        ii, jj = np.nonzero(wing)
        eta = grid.yc[jj] / grid.semispan
        c_loc = grid.chord(grid.yc[jj])
        h = mesh_interpolation(mesh, grid.xc[ii], eta) @ shapes / mesh.c_ref
        left = mesh_interpolation(mesh, grid.xf[ii], eta) @ shapes / mesh.c_ref
        right = mesh_interpolation(mesh, grid.xf[ii + 1], eta) @ shapes / mesh.c_ref
        slope = (right - left) / (c_loc * (grid.xf[ii + 1] - grid.xf[ii]))[:, None]
        return np.asarray(h), np.asarray(slope), wing

    def check_grid(self, grid: TsdGrid, m: int) -> None:
        """Refuse a grid too coarse for m shapes."""
        n_cols = int(grid.wing.sum())
        if n_cols < MIN_WING_COLUMNS_PER_SHAPE * m:
            raise InputError("grid", f"{n_cols} wing node columns cannot carry {m} shapes; "
                             f"need at least {MIN_WING_COLUMNS_PER_SHAPE * m} (refine grid.n_chord or grid.n_span)")

    # ----- runs -------------------------------------------------------------------------------------------------
    def check_mach(self, mach: float) -> float:
        """Validate a free-stream Mach number for the TSD (MIN_MACH <= M < 1)."""
        mach = check_mach(mach, upper=1.0)
        if mach < MIN_MACH:
            raise InputError("mach", f"the TSD solver needs M >= {MIN_MACH} (its factored scheme is unstable at "
                             f"lower Mach; use the dlm solver there), got {mach}")
        return mach

    def time_step(self, grid: TsdGrid) -> float:
        """Internal time step (t*): ``dt``, capped at ``te_cells_per_step`` times the smallest trailing-edge cell,
        halved ``step_halvings`` times (once a run diverged at it).

        The sheared grid scales with the local chord, so a tapered wing's tip has small cells: on the cropped
        delta (taper 0.2, TE cells down to 0.0038 c_ref) dt 0.0167 grew from a perturbed rest state and 0.0143
        decayed (7 internal steps per 0.1 t* signal step instead of 9 at the earlier 3 cells); on AGARD 445.6
        (smallest 0.012) 0.02 is stable.
        """
        i_te = int(np.flatnonzero(grid.xc < 1.0)[-1])
        te = (grid.xf[i_te + 1] - grid.xf[i_te]) * grid.chord(grid.yc[grid.strips]).min()
        return float(min(self.dt, self.te_cells_per_step * te)) * 0.5 ** self.step_halvings

    def _halve_step(self, grid: TsdGrid, exc: Diverged) -> None:
        """After a diverged run: halve the step for this and every later run, or raise ``exc`` when the halvings
        allowed are spent."""
        if exc.spent:
            raise exc
        if self.step_halvings >= self.max_step_halvings:
            raise Diverged(f"{exc} (after {self.step_halvings} halvings of the step; refine the time step with "
                           "tsd_dt)", spent=True) from exc
        self.step_halvings += 1

    def steady_budget(self, dt: float) -> int:
        """Steps of ``dt`` (t*) the steady march may take: ``steady_steps`` steps of STEADY_DT, the same pseudo-time
        whatever ``dt`` is (it was ``steady_steps`` steps of ``dt``: halving ``tsd_dt`` halved the budget in t*, and
        the AGARD grid x 2 at dt 0.01 stopped unconverged after 25 t*, docs/transonic.md 7.13)."""
        return int(self.steady_steps * STEADY_DT / dt)

    def n_sub_at(self, mach: float) -> int:
        """Sub-iterations per time step at ``mach``."""
        return self.n_sub if self.n_sub is not None else sub_iterations(mach)

    def mean_flow(self, mesh: StandardMesh, mach: float, progress: ProgressFn | None = None,
                  share: float = 1.0) -> TsdFlow:
        """Converged steady flow about the wing's thickness at ``mach``; keeps its Cp in ``last_mean_flow``."""
        mach = self.check_mach(mach)
        grid = self.build_grid(mesh)
        while True:
            key = self._steady_key(mesh, mach)
            if self._steady is not None and self._steady[0] == key:
                self.last_mean_flow = self._steady[2]
                if progress is not None:
                    progress(share, f"steady mean flow: the converged state of {self.last_mean_flow.steady.steps} "
                             "steps, reused")
                return copy.deepcopy(self._steady[1])
            try:
                flow = self._mean_flow(grid, mach, progress, share)
            except Diverged as exc:
                self._halve_step(grid, exc)
                continue
            assert self.last_mean_flow is not None
            self._steady = (key, copy.deepcopy(flow), self.last_mean_flow)
            return flow

    def _steady_key(self, mesh: StandardMesh, mach: float) -> tuple[Any, ...]:
        """What a steady state depends on: the planform, the Mach number, every setting and the current step."""
        settings = tuple((f.name, repr(getattr(self, f.name))) for f in fields(self)
                         if f.init and f.name not in ("record_threads", "name"))
        return repr(mesh.planform), float(mach), self.step_halvings, settings

    def _mean_flow(self, grid: TsdGrid, mach: float, progress: ProgressFn | None, share: float) -> TsdFlow:
        """One steady march at the current step (``mean_flow``); Diverged when its field became non-finite."""
        flow = TsdFlow(grid, tsd_coefficients(mach, self.coefficients), sponge_rate=self.sponge_rate,
                       cross_upwind=self.cross_upwind, far_field=self.far_field)
        slope = self._thickness_slope(grid)[:, None]
        flow.w_up[...] = np.where(grid.wing, slope, 0.0)
        flow.w_lo[...] = np.where(grid.wing, -slope, 0.0)

        def check(step: int, nmax: float, change: float) -> None:
            if progress is not None and (step % 25 == 0 or step == 1):
                progress(share * min(1.0, step * dt / (self.steady_steps * STEADY_DT)),
                         f"steady mean flow: step {step}, residual {nmax:.2e}, dphi/dt {change:.2e}")

        dt = self.time_step(grid)
        result = flow.solve_steady(dt=dt, max_steps=self.steady_budget(dt), tol=self.steady_tol,
                                   n_sub=self.n_sub_at(mach), check=check)
        if not np.all(np.isfinite(flow.phi)):
            raise Diverged(f"TSD steady solution diverged at M = {mach}, dt {dt:.4g} t*")
        up, lo = flow.surface_cp()
        iw = np.flatnonzero((grid.xc > 0) & (grid.xc < 1))
        jw = np.flatnonzero(grid.strips)  # the wing's stations (not a free wing's columns below the root)
        self.last_mean_flow = MeanFlow(mach=mach, x_over_c=grid.xc[iw], eta=grid.yc[jw] / grid.semispan,
                                       cp_upper=up[np.ix_(iw, jw)], cp_lower=lo[np.ix_(iw, jw)],
                                       cp_star=flow.coef.cp_star, steady=result, dt=dt,
                                       step_halvings=self.step_halvings, far_field=self.far_field)
        return flow

    def simulate(self, mesh: StandardMesh, shapes: np.ndarray, signals: np.ndarray, mach: float, dt_star: float,
                 progress: ProgressFn | None = None) -> np.ndarray:
        """GAC [T, m] (m^3) of shapes [N, m] (m) moving by signals [T, m], about the steady mean flow at ``mach``."""
        return self.simulate_records(mesh, shapes, [signals], mach, dt_star, progress)[0]

    def simulate_records(self, mesh: StandardMesh, shapes: np.ndarray, records: list[np.ndarray], mach: float,
                         dt_star: float, progress: ProgressFn | None = None) -> list[np.ndarray]:
        """GAC [T_r, m] (m^3) of each record [T_r, m], every one from rest about one steady mean flow at ``mach``.

        The records are independent runs: they are marched at the same time on up to ``record_threads`` threads
        (None: one per record, at most the cores this process may use). The numba kernels release the GIL. A run
        that diverges is repeated from the steady state with the step halved (up to ``max_step_halvings``).
        """
        mach = self.check_mach(mach)
        dt_star = check_dt_star(dt_star)
        shapes = check_shapes(mesh, shapes)
        records = [check_signals(r, shapes.shape[1]) for r in records]
        grid = self.build_grid(mesh)
        self.check_grid(grid, shapes.shape[1])
        while True:
            try:
                return self._simulate_records(mesh, shapes, records, mach, dt_star, progress)
            except Diverged as exc:
                self._halve_step(grid, exc)

    def _simulate_records(self, mesh: StandardMesh, shapes: np.ndarray, records: list[np.ndarray], mach: float,
                          dt_star: float, progress: ProgressFn | None) -> list[np.ndarray]:
        """One attempt of ``simulate_records`` (checked inputs) at the current step."""
        flow = self.mean_flow(mesh, mach, progress, share=0.2)
        march = _March.build(self, mesh, flow, shapes, dt_star, mach)
        march.check_amplitude(records)
        n_threads = self.record_threads or min(len(records), len(os.sched_getaffinity(0)))
        shared = _SharedProgress(progress, [r.shape[0] for r in records], direct=n_threads <= 1)
        flows = [flow, *(copy.deepcopy(flow) for _ in records[1:])]  # copies of the steady state, before any run
        if n_threads <= 1 or len(records) == 1:
            return [march.run(f, r, shared.part(i)) for i, (f, r) in enumerate(zip(flows, records, strict=True))]
        with ThreadPoolExecutor(max_workers=n_threads) as pool:
            futures = [pool.submit(march.run, f, r, shared.part(i))
                       for i, (f, r) in enumerate(zip(flows, records, strict=True))]
            try:
                shared.watch(futures)
                wait(futures)  # the others stop at their next report once one failed
                errors = [e for e in (f.exception() for f in futures) if e is not None]
                real = [e for e in errors if not isinstance(e, Cancelled)]
                if errors:
                    raise (real or errors)[0]  # the record that failed, not one stopped because of it
                return [fut.result() for fut in futures]
            finally:
                shared.stop.set()  # the other records stop at their next report when one fails or is cancelled


class _SharedProgress:
    """Progress of several records marched at once, reported by the calling thread; a stop flag shared by all.

    The marching threads only count their steps (``part``); the caller's thread calls ``progress`` (which may
    write to a database connection bound to that thread, or raise Cancelled) from ``watch``.
    """

    def __init__(self, progress: ProgressFn | None, lengths: list[int], direct: bool) -> None:
        self.progress, self.lengths, self.direct = progress, lengths, direct
        self.done = [0] * len(lengths)
        self.message = ""
        self.stop = threading.Event()

    def fraction(self) -> float:
        """Share of all records' signal steps done (0..1)."""
        return sum(self.done) / max(1, sum(self.lengths))

    def part(self, i: int) -> Callable[[int, str], None]:
        """The step counter of record i: (signal steps done, message); raises Cancelled once the run stops."""
        label = f"record {i + 1}/{len(self.lengths)}: " if len(self.lengths) > 1 else ""

        def report(n_done: int, msg: str) -> None:
            if self.stop.is_set():
                raise Cancelled("another record of this run stopped")
            self.done[i], self.message = n_done, label + msg
            if self.direct and self.progress is not None:
                self.progress(0.2 + 0.8 * self.fraction(), self.message)
        return report

    def watch(self, futures: list[Future[np.ndarray]], every_s: float = 1.0) -> None:
        """Report progress every ``every_s`` seconds until all records finish or one fails (then stop the rest)."""
        pending = set(futures)
        last = -1.0
        while pending:
            finished, pending = wait(pending, timeout=every_s, return_when=FIRST_EXCEPTION)
            if any(f.exception() is not None for f in finished):
                self.stop.set()
                return
            if self.progress is not None and self.fraction() != last:
                last = self.fraction()
                try:
                    self.progress(0.2 + 0.8 * last, self.message)
                except BaseException:
                    self.stop.set()
                    raise


@dataclass
class _March:
    """What the time-accurate run of one record needs: the shapes on the grid and the step sizes."""

    h: np.ndarray  # [n_wing, m] shape values / c_ref
    hx: np.ndarray  # [n_wing, m] shape slopes
    wing: np.ndarray  # [ni, nj] planform node mask
    weights: np.ndarray  # [n_wing, m] cell lift -> GAC (m^3)
    f_mean: np.ndarray  # [m] GAC of the mean flow
    w_up0: np.ndarray
    w_lo0: np.ndarray
    dt_star: float
    n_int: int
    n_sub: int
    mach: float

    @classmethod
    def build(cls, solver: TsdSolver, mesh: StandardMesh, flow: TsdFlow, shapes: np.ndarray, dt_star: float,
              mach: float) -> _March:
        """Shape operators, GAC weights and internal steps of ``solver`` for shapes [N, m] (m) about ``flow``."""
        grid = flow.grid
        h, hx, wing = solver._shape_operators(mesh, grid, shapes)
        dy = np.broadcast_to(np.diff(grid.yf)[None, :], wing.shape)[wing]
        weights = h * (dy * mesh.c_ref ** 3)[:, None]  # [n_wing, m]: cell lift (c_ref units) -> GAC (m^3)
        n_int = max(1, math.ceil(dt_star / solver.time_step(grid) - 1e-9))
        return cls(h=h, hx=hx, wing=wing, weights=weights, f_mean=flow.cell_lift()[wing] @ weights,
                   w_up0=flow.w_up[wing].copy(), w_lo0=flow.w_lo[wing].copy(), dt_star=dt_star, n_int=n_int,
                   n_sub=solver.n_sub_at(mach), mach=mach)

    def downwash(self, signals: np.ndarray) -> np.ndarray:
        """[n_wing, T] surface downwash dh/dx + dh/dt (U units) of signals [T, m] at the signal samples."""
        udot = np.diff(np.vstack([np.zeros((1, signals.shape[1])), signals]), axis=0) / self.dt_star
        return np.asarray(self.hx @ signals.T + self.h @ udot.T)

    def check_amplitude(self, records: list[np.ndarray]) -> None:
        """Refuse motions whose surface downwash exceeds MAX_SURFACE_DOWNWASH (InputError naming ``signals``)."""
        worst = max(float(np.max(np.abs(self.downwash(r)), initial=0.0)) for r in records)
        if not worst <= MAX_SURFACE_DOWNWASH:
            raise InputError("signals", f"the motion tilts the surface by up to {worst:.3g} (dh/dx + dh/dt, U units); "
                             f"the small-disturbance solver takes at most {MAX_SURFACE_DOWNWASH}: reduce the amplitude")

    def run(self, flow: TsdFlow, signals: np.ndarray, report: Callable[[int, str], None]) -> np.ndarray:
        """GAC [T, m] (m^3) of one record [T, m] marched on ``flow`` from its steady state (u = 0 before n = 0)."""
        wing, dt = self.wing, self.dt_star / self.n_int
        n_t = signals.shape[0]
        u_sub, udot_sub = substep_inputs(signals, self.n_int, self.dt_star)
        gac = np.zeros((n_t, signals.shape[1]))
        t_wall = time.perf_counter()
        flow.start_unsteady()
        for n in range(n_t):
            for sub in range(self.n_int):
                w_mod = self.hx @ u_sub[n, sub] + self.h @ udot_sub[n, sub]
                flow.w_up[wing] = self.w_up0 + w_mod
                flow.w_lo[wing] = self.w_lo0 + w_mod
                try:
                    flow.step(dt, self.n_sub)
                except (ZeroDivisionError, FloatingPointError) as exc:
                    raise Diverged(f"TSD unsteady run diverged at step {n} (M = {self.mach}): {exc}") from exc
            gac[n] = flow.cell_lift(dt)[wing] @ self.weights - self.f_mean
            if not np.all(np.isfinite(gac[n])):
                raise Diverged(f"TSD unsteady run diverged at step {n} (M = {self.mach}, dt {dt:.4g} t*)")
            if n % 20 == 0 or n == n_t - 1:
                report(n + 1, f"unsteady: step {n + 1}/{n_t} ({time.perf_counter() - t_wall:.0f} s)")
        return gac


__all__ = ["TsdSolver", "MeanFlow", "Cancelled", "Diverged", "check_thickness", "mesh_interpolation"]
