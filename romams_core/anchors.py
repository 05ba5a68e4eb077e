"""Harmonic anchors of a discrete aerodynamic ROM: direct solver runs of each shape at a few low reduced
frequencies, and the parallel lag correction that makes the ROM reproduce them exactly.

An ARX ROM of an m-shape basis fits every output to about 1 % of its RMS. A structure's small generalized force
entries are mixtures of those outputs, so at the low reduced frequencies where a transonic flutter is decided
they can be several percent off (docs/transonic.md 7.2). Anchors add what the multisine records lack.

Correction (derivation in docs/transonic.md 7.7). With residuals R_j = G_direct(k_j) - G_rom(k_j) at K anchors,
z_j = exp(2 i k_j dt*), the correction is

    dG(z) = E_0 + sum_l E_l (z - 1) / (z - rho_l),    rho_l = exp(-2 beta_l dt*)

with real matrices E_l [p, m] and L = 2 K - 1 lag poles beta_l (reduced frequency on the semichord): 2 K real
equations per entry for 2 K unknowns, solved once for all entries. Each lag term is realized with m states
w(n+1) = rho w(n) + u(n), output E_l ((rho - 1) w + u), in parallel to the ROM: A, B, C, D grow by L m states.
The lag terms vanish at k = 0 and tend to E_l at high k: the correction is bounded at every frequency.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, TypeVar

import numpy as np
import scipy.linalg as sla

from romams_core.aero.protocol import ProgressFn, RecordsSolver, UnsteadySolver
from romams_core.errors import InputError
from romams_core.mesh import StandardMesh
from romams_core.statespace import ContinuousSS, DiscreteSS
from romams_core.validation import check_number

SS = TypeVar("SS", DiscreteSS, ContinuousSS)

__all__ = ["tone_amplitudes", "tone_records", "harmonic_anchors", "check_anchor_hold", "step_records",
           "step_transfer", "step_anchors", "anchor_lags", "anchored", "with_lag_terms"]

#: how long a step record holds the shape (t*): the cropped-delta basis at M 0.95, whose upstream acoustic waves
#: settle slowest, matches the tone runs at k 0.05 / 0.1 to 0.05 % of the largest entry from 120 t* on (0.3 % at
#: 80 t*; docs/transonic.md 7.11)
STEP_HOLD = 120.0
#: cosine ramp of a step record (t*): smooth enough for the sub-step motion, short against the hold
STEP_RAMP = 2.0
#: longest step record (t*) a training may ask for
STEP_HOLD_MAX = 2000.0


def tone_amplitudes(x: np.ndarray, t: np.ndarray, omegas: np.ndarray) -> np.ndarray:
    """Complex amplitudes [n_tones, ...] of x ~ sum Re(c_j e^{i w_j t}) + const by least squares (x [T] or [T, p];
    t and w in the same time units)."""
    cols = [np.ones_like(t)]
    for w in omegas:  # a few tones
        cols += [np.cos(w * t), -np.sin(w * t)]
    coef = np.linalg.lstsq(np.column_stack(cols), x, rcond=None)[0]
    return coef[1::2] + 1j * coef[2::2]


def check_anchor_k(k: Sequence[float] | np.ndarray, k_max: float) -> np.ndarray:
    """Anchor reduced frequencies, sorted; InputError naming ``anchor_k`` unless 1-4 distinct values in (0, k_max]."""
    try:
        arr = np.atleast_1d(np.asarray(k, dtype=float))
    except (TypeError, ValueError):
        raise InputError("anchor_k", f"must be a list of reduced frequencies, got {k!r}") from None
    if arr.ndim != 1 or arr.size == 0 or arr.size > 4 or not np.all(np.isfinite(arr)):
        raise InputError("anchor_k", f"must be 1 to 4 finite reduced frequencies, got {k!r}")
    if np.any(arr <= 0.0) or np.any(arr > k_max) or np.unique(arr).size != arr.size:
        raise InputError("anchor_k", f"must be distinct and in (0, k_max = {k_max:g}], got {arr.tolist()}")
    return np.sort(arr)


def tone_records(shapes: np.ndarray, c_ref: float, k: np.ndarray, dt_star: float,
                 peak_fraction: float) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
    """(one record [T, m] per shape: that shape alone at the tones k, its peak surface displacement
    ``peak_fraction`` c_ref; t [T] in t*; the analysed samples [T] bool).

    The tones (w = 2 k, t* = t V / c_ref) ramp in over one period of the lowest, then a quarter period lets the
    ramp's end decay, then one period of the lowest is analysed: a whole number of periods of each tone when the
    tones are multiples of the lowest."""
    om = 2.0 * np.asarray(k, dtype=float)
    period = 2.0 * math.pi / om.min()
    t = np.arange(int(round(2.25 * period / dt_star)) + 1) * dt_star
    wave = np.sin(np.outer(t, om)).sum(axis=1) * np.minimum(1.0, t / period) / om.size
    return _each_shape_alone(shapes, peak_fraction * c_ref * wave), t, t >= t[-1] - period


def _each_shape_alone(shapes: np.ndarray, motion: np.ndarray) -> list[np.ndarray]:
    """One record [T, m] per shape: that shape alone, its peak surface displacement following ``motion`` [T] (m)."""
    peak = np.abs(shapes).max(axis=0)
    if np.any(peak <= 0.0):
        raise InputError("shapes", "a shape without displacement cannot be run")
    records = []
    for col in range(shapes.shape[1]):  # m records
        sig = np.zeros((motion.size, shapes.shape[1]))
        sig[:, col] = motion / peak[col]
        records.append(sig)
    return records


def _run_records(solver: UnsteadySolver, mesh: StandardMesh, shapes: np.ndarray, records: list[np.ndarray],
                 mach: float, dt_star: float, progress: ProgressFn | None) -> list[np.ndarray]:
    """GAC [T, p] of each record: side by side for a RecordsSolver, else one run after the other."""
    if isinstance(solver, RecordsSolver):
        return solver.simulate_records(mesh, shapes, records, mach, dt_star, progress=progress)
    return [np.asarray(solver.simulate(mesh, shapes, r, mach, dt_star)) for r in records]


def harmonic_anchors(solver: UnsteadySolver, mesh: StandardMesh, shapes: np.ndarray, mach: float, k: np.ndarray,
                     dt_star: float = 0.1, peak_fraction: float = 0.002,
                     progress: ProgressFn | None = None) -> np.ndarray:
    """Transfer matrix [n_k, m, m] (m^3 per unit generalized displacement) of ``solver`` at the reduced frequencies
    k (on c_ref / 2) from one multi-tone run per shape (``tone_records``), side by side for a RecordsSolver."""
    k = np.asarray(k, dtype=float)
    records, t, last = tone_records(shapes, mesh.c_ref, k, dt_star, peak_fraction)
    outs = _run_records(solver, mesh, shapes, records, mach, dt_star, progress)
    om = 2.0 * k
    cols = [tone_amplitudes(np.asarray(g)[last], t[last], om) / tone_amplitudes(r[last, j], t[last], om)[:, None]
            for j, (g, r) in enumerate(zip(outs, records, strict=True))]
    return np.stack(cols, axis=2)  # [n_k, p, m]: column j from run j


def check_anchor_hold(hold: Any, ramp: float = STEP_RAMP) -> float:
    """Hold of a step record (t*), or InputError naming ``anchor_hold`` unless within [10 ramp, STEP_HOLD_MAX]."""
    return check_number("anchor_hold", hold, 10.0 * ramp, strict=False, upper=STEP_HOLD_MAX, upper_strict=False)


def step_records(shapes: np.ndarray, c_ref: float, hold: float = STEP_HOLD, dt_star: float = 0.1,
                 peak_fraction: float = 0.002, ramp: float = STEP_RAMP) -> list[np.ndarray]:
    """One record [T, m] per shape: that shape alone, raised by a cosine ramp over ``ramp`` t* until its peak
    surface displacement is ``peak_fraction`` c_ref, then held until ``hold`` t*."""
    hold = check_anchor_hold(hold, ramp)
    t = np.arange(int(round(hold / dt_star)) + 1) * dt_star
    s = np.where(t < ramp, 0.5 * (1.0 - np.cos(np.pi * t / ramp)), 1.0)
    return _each_shape_alone(shapes, peak_fraction * c_ref * s)


def step_transfer(y: np.ndarray, u: np.ndarray, k: np.ndarray, dt_star: float) -> np.ndarray:
    """Column [n_k, p] of the discrete transfer matrix at reduced frequencies k (on c_ref / 2) from one record
    started at rest: sum dy_n z^-n / sum du_n z^-n, z = exp(2 i k dt*) (y [T, p] outputs, u [T] the moving shape's
    input). Exact for a linear system once dy has died out within the record (k = 0: the settled gain)."""
    n = np.arange(1, y.shape[0])
    zn = np.exp(-2j * np.outer(np.asarray(k, dtype=float), n) * dt_star)  # [n_k, T - 1]
    return (zn @ np.diff(y, axis=0)) / (zn @ np.diff(u))[:, None]


def step_anchors(solver: UnsteadySolver, mesh: StandardMesh, shapes: np.ndarray, mach: float, k: np.ndarray,
                 dt_star: float = 0.1, peak_fraction: float = 0.002, hold: float = STEP_HOLD,
                 progress: ProgressFn | None = None, columns: list[int] | None = None) -> np.ndarray:
    """Transfer matrix [n_k, m, m] (m^3 per unit generalized displacement) of ``solver`` at the reduced frequencies
    k (on c_ref / 2) from one step record per shape (``step_records``), side by side for a RecordsSolver. One run
    serves every k whose response has settled within ``hold`` (k = 0 included), unlike ``harmonic_anchors``.
    ``columns``: run only these shapes' motions (default all); the result is then [n_k, m, len(columns)]."""
    records = step_records(shapes, mesh.c_ref, hold, dt_star, peak_fraction)
    moving = list(range(len(records))) if columns is None else [int(j) for j in columns]
    if not moving or not all(0 <= j < len(records) for j in moving):
        raise InputError("columns", f"expected shape indices in [0, {len(records)}), got {columns}")
    outs = _run_records(solver, mesh, shapes, [records[j] for j in moving], mach, dt_star, progress)
    cols = [step_transfer(np.asarray(g), records[j][:, j], np.asarray(k, dtype=float), dt_star)
            for j, g in zip(moving, outs, strict=True)]
    return np.stack(cols, axis=2)  # [n_k, p, len(moving)]: column c from the run of shape moving[c]


def anchor_lags(k: np.ndarray) -> np.ndarray:
    """The 2 K - 1 lag poles beta (reduced frequency) for K anchors: geometric from k_min to 2 k_max (K = 1: k).

    Measured on the cropped-delta basis at M 0.95 (docs/transonic.md 7.7): with anchors at 0.05 / 0.1, lags
    0.05 / 0.1 / 0.2 kept the validation NRMSE at 1.69 % (unanchored 1.51 %), 0.025 / 0.07 / 0.2 at 2.17 %, and
    0.1 / 0.3 / 1.0 let it grow to 37 %: poles far above the anchors need large, cancelling E_l."""
    k = np.asarray(k, dtype=float)
    n = 2 * k.size - 1
    return np.geomspace(k.min(), 2.0 * k.max(), n) if n > 1 else np.array([k.min()])


def anchored(ss: SS, k: np.ndarray, gaf: np.ndarray, lags: np.ndarray | None = None) -> SS:
    """``ss`` with the parallel lag correction (module docstring) that reproduces ``gaf`` [n_k, p, m] at k exactly."""
    k = np.asarray(k, dtype=float)
    gaf = np.asarray(gaf)
    if gaf.shape != (k.size, ss.n_outputs, ss.n_inputs) or not np.all(np.isfinite(gaf)):
        raise InputError("anchor_gaf", f"expected finite [{k.size}, {ss.n_outputs}, {ss.n_inputs}], got {gaf.shape}")
    return with_lag_terms(ss, k, gaf - ss.freqresp(k), lags)


def with_lag_terms(ss: SS, k: np.ndarray, residual: np.ndarray, lags: np.ndarray | None = None) -> SS:
    """``ss`` plus the lag terms (module docstring) equal to ``residual`` [n_k, p, m] at the reduced frequencies k.

    A continuous model (an RFA ROM, derivatives in t*) gets the same terms in continuous form: E_l s* / (s* + 2
    beta_l), s* = 2 i k, realized by w' = -2 beta_l w + u, output E_l (u - 2 beta_l w)."""
    k = np.asarray(k, dtype=float)
    lags = anchor_lags(k) if lags is None else np.asarray(lags, dtype=float)
    m, p = ss.n_inputs, ss.n_outputs
    if isinstance(ss, ContinuousSS):
        s, a = 2j * k, 2.0 * lags
        phi = np.column_stack([np.ones_like(s)] + [s / (s + r) for r in a])  # [K, L + 1]
        poles, out_gain = -a, -a
    else:
        z = np.exp(2j * k * ss.dt_star)
        rho = np.exp(-2.0 * lags * ss.dt_star)
        phi = np.column_stack([np.ones_like(z)] + [(z - 1.0) / (z - r) for r in rho])
        poles, out_gain = rho, rho - 1.0
    res = np.asarray(residual).reshape(k.size, p * m)
    e = np.linalg.lstsq(np.vstack([phi.real, phi.imag]), np.vstack([res.real, res.imag]), rcond=None)[0]
    e = e.reshape(lags.size + 1, p, m)
    parts = dict(A=sla.block_diag(ss.A, np.kron(np.diag(poles), np.eye(m))),
                 B=np.vstack([ss.B] + [np.eye(m)] * lags.size),
                 C=np.hstack([ss.C] + [g * e[i + 1] for i, g in enumerate(out_gain)]),
                 D=ss.D + e.sum(axis=0))
    if isinstance(ss, ContinuousSS):
        return ContinuousSS(**parts, D1=ss.D1, D2=ss.D2)  # type: ignore[return-value]
    return DiscreteSS(**parts, dt_star=ss.dt_star)
