"""flutter_analysis / flutter_batch: flutter searches at one Mach number (model, sweep, tracking, crossing)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from romams_core.errors import InputError
from romams_core.validation import finite_positive

from .batch import run_one, run_searches
from .continuation import ContinuationTracker, kernel_sweep
from .crossing import make_bracket, refine_crossing
from .curves import vg_curves
from .inputs import check_flutter_inputs, check_search_options
from .model import Model, make_model
from .point import frequency_separation, modal_shares, single_mode_unstable
from .result import FlutterResult, no_flutter_fields
from .sweeps import DEFAULT_ALTITUDE_REF_M, ConstantDensity, Sweep, eas, make_sweep, resolve_reference
from .tracking import G_UNSTABLE, Branches, Path, Solve, Tracker


@dataclass(frozen=True)
class _Search:
    """A validated flutter search: model, sweep and options (``prepare_search``)."""

    model: Model
    sweep: Sweep
    head: dict[str, Any]
    n_points: int
    sdoff_share: float
    sdoff_q_factor: float
    track_weight: float
    rtol: float
    k_band: float | None
    tracking: str
    k_gate: float = math.inf  # band above which an unstable branch is not counted (constant density, 9.10)
    vg_checks: bool = True  # verify the V-g curves after the crossing too (continuation checkpoints)


TRACKERS = {"continuation": ContinuationTracker, "eigen": Tracker}  # docs/flutter.md 9.7
DEFAULT_TRACKING = "auto"  # "continuation" where its steps are compiled (diagonalized Tustin aero matrix, constant-
# speed or constant-density sweep: a third of the eigen-solves, docs/performance.md 6b), else "eigen" (the same
# flutter points; the continuation's Python steps of the other cases cost more than the solves they save)


def resolve_tracking(tracking: str, model: Model, sweep: Sweep) -> str:
    """The tracker of a search: ``tracking`` itself, or for "auto" the one ``DEFAULT_TRACKING`` describes."""
    if tracking != "auto":
        return tracking
    return "continuation" if kernel_sweep(model, sweep) is not None else "eigen"


def flutter_analysis(omega: np.ndarray, aero: Any, c_ref: float, mach: float, **options: Any) -> FlutterResult:
    """Flutter search at one Mach number for structure ``omega`` [k] (rad/s) and modal aero ROM ``aero``.

    ``aero`` has A, B, C, D, dt_star (discrete, t* = t V / c_ref, inputs xi, outputs f = F / q); ``c_ref`` in m.
    ``options`` (keywords of ``prepare_search``): sweep ("constant-speed"), coupling ("tustin"), zeta, the reference
    state (altitude_ref_m = 10 km, or rho_ref, a_ref), the ranges v_max (m/s, constant-density; default 3 M a_ref,
    at Mach 0 omega_max c_ref), q_max (Pa, constant-speed; default 4 x 0.5 rho_ref (M a_ref)^2), altitude_range_m
    (matched); n_points coarse sweep points (the tracker refines where needed, so the flutter point does not depend
    on it); rtol of the crossing (brentq, then polished to 1e-11); tracking: "eigen" (one full eigen-solve per sweep
    point, ``tracking.Tracker``), "continuation" (Newton on det T(s) between a few eigen-solves,
    ``continuation.ContinuationTracker``; the same flutter points) or "auto" (default: ``DEFAULT_TRACKING``); SDOFF
    when the flutter vector's largest modal share is >= sdoff_share AND that mode alone is unstable at q <=
    sdoff_q_factor q_f; k_band (reduced frequency on c_ref / 2): a flutter point above the band the ROM was
    identified in is flagged ``outside_band``, and in a constant-density sweep an unstable run that stays above
    the band and ends is not counted as flutter (``band_gate``, ``counted_onset``, ``unstable_above_band_v_m_s``).
    ``vg_checks`` False: the continuation skips the full-spectrum checks that can only correct the V-g curves after
    the crossing (the flutter point is the same; for searches whose curves are not kept, docs/performance.md 6c).
    Reports the TRUE speed ``v_flutter_m_s`` and the equivalent airspeed ``v_eas_m_s``; no flutter in range is a
    result with flutter_found False. Invalid input raises romams_core.errors.InputError naming the field. The same
    search as one member of ``flutter_batch``.
    """
    return run_one(flutter_search(prepare_search(omega, aero, c_ref, mach, **options)))


def flutter_batch(designs: Sequence[tuple[np.ndarray, Any]], c_ref: float, mach: float,
                  **options: Any) -> list[FlutterResult]:
    """Flutter searches of many structures (omega [k] rad/s, modal aero ROM) at one Mach, run together.

    Same options and results as ``flutter_analysis`` (equal to it design by design); every sweep step of all
    designs is one batched eigen-solve (``batch.run_searches``). Every design is validated before any search runs.
    """
    searches = [prepare_search(om, aero, c_ref, mach, **options) for om, aero in designs]
    return run_searches([flutter_search(s) for s in searches])


def prepare_search(
    omega: np.ndarray, aero: Any, c_ref: float, mach: float, *, sweep: str = "constant-speed",
    coupling: str = "tustin", zeta: np.ndarray | float | None = None,
    altitude_ref_m: float = DEFAULT_ALTITUDE_REF_M, rho_ref: float | None = None, a_ref: float | None = None,
    v_max: float | None = None, q_max: float | None = None,
    altitude_range_m: tuple[float, float] = (0.0, 20_000.0), n_points: int = 12, sdoff_share: float = 0.9,
    sdoff_q_factor: float = 1.1, track_weight: float = 0.5, rtol: float = 1e-4, k_band: float | None = None,
    tracking: str = DEFAULT_TRACKING, vg_checks: bool = True,
) -> _Search:
    """The validated search of ``flutter_analysis`` (its docstring; InputError naming the field)."""
    om, zt, c_ref, mach = check_flutter_inputs(omega, zeta, c_ref, mach, sweep)
    check_search_options(coupling, n_points, sdoff_share, sdoff_q_factor, rtol)
    model = make_model(om, zt, c_ref, aero, coupling)
    rho_ref, a_ref, h_ref = resolve_reference(altitude_ref_m, rho_ref, a_ref)
    sw = make_sweep(sweep, mach, om, c_ref, rho_ref, a_ref, v_max, q_max, altitude_range_m)
    head: dict[str, Any] = dict(mach=mach, sweep=sweep, coupling=coupling, rho_ref=rho_ref, a_ref=a_ref,
                                c_ref=c_ref, dt_star=model.dt_star, altitude_ref_m=h_ref)
    if tracking not in TRACKERS and tracking != "auto":
        raise InputError("tracking", f"must be one of {sorted(TRACKERS) + ['auto']}, got {tracking!r}")
    band = None if k_band is None else finite_positive("k_band", k_band)
    return _Search(model, sw, head, int(n_points), float(sdoff_share), float(sdoff_q_factor), track_weight,
                   float(rtol), band, resolve_tracking(tracking, model, sw), band_gate(sw, band), bool(vg_checks))


def band_gate(sweep: Sweep, k_band: float | None) -> float:
    """The band above which an unstable branch is not counted as flutter (docs/flutter.md 9.10): ``k_band`` in a
    constant-density sweep, whose start at V -> 0 takes every mode above any ROM's band; else none (inf: a
    constant-speed or matched sweep keeps its reduced frequencies, and a crossing above the band is reported with
    ``outside_band``)."""
    return math.inf if k_band is None or not isinstance(sweep, ConstantDensity) else k_band


def flutter_search(se: _Search) -> Solve[FlutterResult]:
    """The search (a generator of eigen requests, batch.py) -> FlutterResult."""
    sw, om = se.sweep, se.model.omega
    tracker = TRACKERS[se.tracking](se.model, sw, se.track_weight, se.k_gate)
    tracker.vg_checks = se.vg_checks
    path = yield from tracker.track_search(sw.grid(se.n_points))
    cands = counted_onset(tracker, path)
    above = _unstable_above_band(tracker, path)
    head: dict[str, Any] = dict(se.head, **_vg_data(sw, path), modal_share=np.zeros(om.size),
                                lag_root_flagged=path.lag, unstable_above_band_v_m_s=above)
    if path.first_unstable is None:
        msg = f"no flutter up to {sw.range_text()}{_lag_note(path)}{_above_note(above, se.k_gate)}"
        head["curves"] = yield from vg_curves(tracker, path, None)
        return FlutterResult(**no_flutter_fields(), message=msg, **head)
    br = yield from make_bracket(tracker, path, cands)
    p_f, branch, st_f = yield from refine_crossing(tracker, br, se.rtol)
    omega_path = np.array([st.lam.imag for st in path.states[1:path.first_unstable]] + [st_f.lam.imag])
    # unstable from the start: growth near q = 0 is too small to see; check at least 1/12 of the natural range
    p_chk_min = max(sw.p_start + sw.scale_at(sw.p_start) / 12.0, p_f) if path.first_unstable == 1 else p_f
    point = yield from _flutter_point(tracker, p_f, branch, st_f, omega_path, se.sdoff_share, se.sdoff_q_factor,
                                      p_chk_min)
    if path.first_unstable == 1 and p_f == br.lo_p:
        point["message"] = "structural branch already unstable at the start of the sweep; " + point["message"]
    point["message"] += _lag_note(path) + _above_note(above, se.k_gate)
    if se.k_band is not None and point["k_flutter"] > se.k_band:
        point["outside_band"] = True
        point["message"] += (f"; WARNING: k_f = {point['k_flutter']:.3g} is above the band the ROM was identified "
                             f"in (k <= {se.k_band:g}): the ROM is not valid there, so this crossing is not a "
                             "prediction (start the sweep where the modes are inside the band)")
    head["modal_share"] = point.pop("modal_share")
    head["curves"] = yield from vg_curves(tracker, path, (p_f, st_f))  # plot only: after the flutter point
    return FlutterResult(**point, **head)


def counted_onset(tracker: Tracker, path: Path) -> np.ndarray | None:
    """With a band gate: the candidate branches [k] of the first crossing that counts, and ``path.first_unstable``
    moved to its onset (None without a gate: the tracker's first unstable point and its unstable branches).

    An unstable run of a branch (its consecutive unstable path points) counts when it reaches into the band or
    lasts to the end of the sweep; it then counts from its onset, above the band or not (the lower speed: a
    number never on the unsafe side of the ungated search). A run that lies above the band and ends inside the
    sweep is the ROM outside its validity (docs/flutter.md 9.10) and is not counted.
    """
    if math.isinf(tracker.k_gate):
        return None
    i = path.first_unstable
    if i is None:  # nothing in the band: a run still unstable at the sweep's end counts
        i = len(path.p) - 1
        counted = path.g(i) > G_UNSTABLE
        if i < 1 or not counted.any():
            return None
    else:
        counted = tracker.unstable(path.p[i], path.states[i])
    onset = np.full(counted.size, i)
    for j in np.flatnonzero(counted):
        while onset[j] > 1 and path.g(int(onset[j]) - 1)[j] > G_UNSTABLE:
            onset[j] -= 1
    path.first_unstable = int(onset[counted].min())
    return counted & (onset == path.first_unstable)


def _unstable_above_band(tracker: Tracker, path: Path) -> float | None:
    """Highest true speed (m/s) before the first counted unstable point (or over the path) at which a branch was
    unstable above the band gate, an instability not counted as flutter; None when none was."""
    if math.isinf(tracker.k_gate):
        return None
    end = len(path.p) if path.first_unstable is None else path.first_unstable
    hits = [path.p[i] for i in range(1, end)
            if np.any((path.g(i) > G_UNSTABLE) & ~tracker.in_band(path.p[i], path.states[i]))]
    return None if not hits else float(tracker.sweep.cond(np.array([max(hits)]))[0][0])


def _above_note(v_above: float | None, k_gate: float) -> str:
    """Message suffix when unstable branches above the band were not counted."""
    return ("" if v_above is None else f"; NOTE: a branch was unstable at V <= {v_above:.6g} m/s with its reduced "
            f"frequency above the ROM's band (k > {k_gate:g}), where the ROM is not valid: not counted as flutter")


def _lag_note(path: Path) -> str:
    """Message suffix when a branch had to be continued on an aerodynamic lag root."""
    return ("; WARNING: a structural branch was continued on an aerodynamic lag root (no structural candidate "
            "left) -- check the ROM" if path.lag else "")


def _vg_data(sw: Sweep, path: Path) -> dict[str, np.ndarray]:
    """V-g / V-omega data of the coarse grid points."""
    grid = np.array([path.p[i] for i in path.coarse])
    lam_path = np.array([path.states[i].lam for i in path.coarse])
    g_path = 2.0 * lam_path.real / np.abs(lam_path)
    v_g, rho_g = sw.cond(grid)
    q_g = 0.5 * rho_g * v_g**2
    keep = sw.keep(grid)
    return dict(v=sw.speed_axis(v_g, q_g)[keep], v_eas=eas(q_g)[keep], q=q_g[keep], rho=rho_g[keep],
                altitude=sw.altitude(grid)[keep], g=g_path[keep], zeta=-0.5 * g_path[keep],
                omega=lam_path.imag[keep])


def _flutter_point(tracker: Tracker, p_f: float, branch: int, st_f: Branches, omega_path: np.ndarray,
                   sdoff_share: float, sdoff_q_factor: float, p_chk_min: float) -> Solve[dict[str, Any]]:
    """Flutter-point fields of the result (speeds, frequency, shares, SDOFF, message)."""
    sw, m = tracker.sweep, tracker.m
    share = modal_shares(st_f, branch)
    energy_share = float(share.max())
    v_f, rho_f = (float(x[0]) for x in sw.cond(np.array([p_f])))
    q_f = 0.5 * rho_f * v_f**2
    single = False
    if energy_share >= sdoff_share:
        p_chk = max(sw.p_check(p_f, q_f, sdoff_q_factor), p_chk_min)
        single = yield from single_mode_unstable(m, sw, int(np.argmax(share)), p_chk, tracker.weight,
                                                 k_gate=tracker.k_gate)
    lam_f = complex(st_f.lam[branch])
    omega_f = abs(lam_f.imag)
    alt = sw.altitude(np.array([max(p_f, 0.0)]))[0]
    message = ""
    if p_f < 0:
        message += f"unstable already at the top altitude {sw.altitude(np.array([0.0]))[0]:.6g} m " \
                   "(flutter altitude above the range); "
    if omega_f <= 1e-6 * float(m.omega.max()):
        message += "zero-frequency crossing (static divergence); "
    v_eas = float(eas(np.array(q_f)))
    message += (f"flutter on structural branch {branch + 1} at q = {q_f:.6g} Pa, true airspeed V = {v_f:.6g} m/s "
                f"(EAS {v_eas:.6g} m/s), omega = {omega_f:.6g} rad/s ({sw.name}, {m.coupling})")
    return dict(
        flutter_found=True, v_flutter_m_s=v_f, v_true_m_s=v_f, v_eas_m_s=v_eas, omega_flutter_rad_s=omega_f,
        q_flutter_pa=q_f, rho_flutter=rho_f, altitude_m=None if math.isnan(alt) else float(alt),
        k_flutter=omega_f * 0.5 * m.c_ref / v_f, flutter_mode=branch + 1,
        sdoff=bool(energy_share >= sdoff_share and single), single_mode_unstable=bool(single),
        energy_share=energy_share, frequency_separation=frequency_separation(omega_path, branch),
        modal_share=share, message=message,
    )
