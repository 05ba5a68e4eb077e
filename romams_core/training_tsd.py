"""Training of a ROM on the transonic small-disturbance solver: mean flow, one multisine run, ARX.

The TSD run is the expensive step (minutes per Mach), so its defaults differ from the UVLM's: a coarser
signal step (dt_star 0.1, subdivided inside the solver to its own stable step), a minimum record of 60 t*
instead of 200, and a peak surface displacement of 0.2 % of c_ref so that shocks move within the
locally linear regime. The ROM is linear about the steady transonic mean flow, which it keeps (surface Cp).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, replace
from typing import Any, cast

import numpy as np

from romams_core.aero.protocol import ProgressFn, image_sign
from romams_core.aero.tsd import TsdSolver
from romams_core.aero.tsd.coefficients import COEFFICIENT_SETS
from romams_core.aero.tsd.grid import GridSpec
from romams_core.aero.tsd.solver import MIN_WING_COLUMNS_PER_SHAPE, MeanFlow, check_thickness
from romams_core.anchors import STEP_HOLD, anchored, check_anchor_hold, check_anchor_k, step_anchors
from romams_core.arx import band_part
from romams_core.errors import InputError
from romams_core.mesh import StandardMesh
from romams_core.training import TrainedRom, TrainingError, check_validation_band, train_rom, with_symmetry
from romams_core.validation import check_number

#: linearity of the GAC under halving the excitation amplitude, at most (relative L2)
LINEARITY_TOL = 0.02


#: default ARX orders (na, nb) of a TSD ROM. Measured on 3 cropped-delta designs (docs/transonic.md 7.2): 8/8 puts
#: ROM-AMS 1.4-24 % below ROM-PMS; 12/12 up to 7.6 % above it at M 0.95. Against direct harmonic TSD runs
#: (benchmarks.tsd_ams_gap) that is scatter of the basis ROM's low-k GAF, and no order 8-16 or input spectrum
#: (low_k_corner) held all designs within 2 %. On the paper case's TSD optimum at M 0.95 (7.10) the 8/8 basis ROM is
#: 3.8 % above the TSD's own flutter point and refits at 8-14 are 3.4-6.1 % above it: no order is safe everywhere.
#: The cure is ``anchor_k`` (direct runs; ROM-AMS within 0.16 % of the TSD points at M 0.95, 7.7), on by default
TSD_ORDERS = (8, 8)

#: default anchors of a TSD ROM (k on c_ref / 2): the band below k 0.1 where the plain ARX scatters, from one step
#: record per shape (``anchors.step_anchors``), so the k need not be known before the training (docs/transonic.md
#: 7.11). ``anchor_k`` None (JSON null) or [] trains a plain ROM, which carries ``UNANCHORED_WARNING``.
DEFAULT_ANCHOR_K = (0.025, 0.05, 0.1)
#: reduced frequencies (c_ref / 2) at which an anchored ROM is checked against the step records between and beyond
#: its anchors: the ``anchor_band_error`` it reports
ANCHOR_BAND_K = tuple(float(v) for v in np.round(np.geomspace(0.01, 0.2, 14), 4))
#: above this band error (share of the largest entry) the anchored ROM says so in its warnings
ANCHOR_BAND_TOL = 0.005

#: the warning an unanchored TSD ROM carries into every flutter result (measured on the paper case's TSD optimum,
#: docs/transonic.md 7.10: the trained ROMs 43 % low to 3.8 % high, refits of their records up to 6.1 % high)
UNANCHORED_WARNING = ("not anchored: the low-k GAF (k < 0.1 on c_ref / 2) of a plain TSD ROM scatters with the ARX "
                      "identification (flutter speeds measured from 43 % low to 6 % high against the TSD's own "
                      "points, docs/transonic.md 7.10); retrain with the default anchors (anchor_k not given, "
                      "docs/transonic.md 7.11)")

#: the warning a TSD ROM of a supercritical mean flow carries into every flutter result: its flutter point depends
#: on the grid, and coarser grids give higher speeds (AGARD 445.6, M 0.96, docs/transonic.md 7.20: halving every
#: cell lowered V_f by 5.7 %; at M 0.901, subcritical, by 0.06 %)
SUPERCRITICAL_WARNING = ("supercritical mean flow (min surface Cp {cp_min:.3f} below the sonic Cp* {cp_star:.3f}): "
                         "the TSD's first-order differencing of the supersonic region makes the flutter point "
                         "grid-dependent, and coarser grids give higher flutter speeds (AGARD 445.6 at M 0.96: "
                         "-5.5 % with grid_scale 1.5, -5.7 % with 2, docs/transonic.md 7.20); check a margin of "
                         "about 6 % or train with the default supercritical_refine (1.5), docs/transonic.md 7.21")


#: every cell count of a TSD grid is multiplied by this when the mean flow on the requested grid is supercritical
#: (``supercritical_refine``): on AGARD 445.6 at M 0.96 the default grid's direct flutter speed is 308.74 m/s, the
#: grids x 1.5 and x 2 give 291.84 and 291.20 m/s (within 0.22 %), so x 1.5 takes the unsafe 5.5-5.7 % grid error
#: out of the default; at M 0.901 (subcritical) halving every cell moves it by 0.06 % (docs/transonic.md 7.20, 7.21)
SUPERCRITICAL_REFINE = 1.5

#: the warning of a ROM trained on the grid refined for its supercritical mean flow (``supercritical_refine``)
REFINED_WARNING = ("supercritical mean flow (min surface Cp {cp_min:.3f} below the sonic Cp* {cp_star:.3f} on the "
                   "requested grid): trained on the grid with every cell count x {factor:g} (supercritical_refine), "
                   "where the flutter point of AGARD 445.6 at M 0.96 is within 0.22 % of the grid x 2 "
                   "(docs/transonic.md 7.21)")


def supercritical_warning(mean_flow: MeanFlow) -> str | None:
    """``SUPERCRITICAL_WARNING`` for a mean flow whose surface Cp falls below the sonic Cp*, else None."""
    if not is_supercritical(mean_flow):
        return None
    return SUPERCRITICAL_WARNING.format(cp_min=mean_flow.cp_min, cp_star=mean_flow.cp_star)


def is_supercritical(mean_flow: MeanFlow) -> bool:
    """True when the mean flow's lowest surface Cp lies below the sonic Cp* (a supersonic region on the wing)."""
    return mean_flow.cp_min < mean_flow.cp_star


def check_supercritical_refine(value: Any) -> float | None:
    """Validate ``supercritical_refine``: None (never refine) or a factor in [1, 4] (InputError naming it)."""
    if value is None:
        return None
    check_number("supercritical_refine", value, 1.0, strict=False, upper=4.0, upper_strict=False)
    return float(value)


def refined_for_mean_flow(solver: TsdSolver, mesh: StandardMesh, mach: float, factor: float | None,
                          progress: ProgressFn | None = None) -> tuple[TsdSolver, str | None]:
    """``solver`` itself, or a copy on its grid refined ``factor`` times when the steady mean flow at ``mach`` on
    its own grid is supercritical, with the ROM's warning that says so. A flat section is never supercritical (its
    mean flow is the free stream), so only a thick one costs the steady run on the requested grid."""
    if factor is None or factor == 1.0 or solver.thickness_form is None:
        return solver, None
    solver.mean_flow(mesh, mach, progress, share=0.05)
    coarse = solver.last_mean_flow
    if coarse is None or not is_supercritical(coarse):
        return solver, None
    refined = replace(solver, grid=solver.grid.scaled(factor))
    return refined, REFINED_WARNING.format(cp_min=coarse.cp_min, cp_star=coarse.cp_star, factor=factor)


#: the TSD ROMs' validation NRMSE counts the records at k <= this only (``train_rom``'s ``validation_band``; twice
#: the default k_max): on the AGARD grid x 1.5 at M 0.96 (supercritical) 4-17 % of the validation GAC's RMS lies near
#: k 14, where the multisine has 0.01 % of its RMS, and the ARX's in-band error is 0.2-1.8 % (docs/transonic.md 7.21)
TSD_VALIDATION_BAND = 3.0

#: further ARX orders tried on the same records when the requested ones miss nrmse_tol (a refit costs seconds; the
#: TSD run minutes): the cropped delta's own modes at M 0.87 missed 5 % with 8/8 on one output (5.97 %)
ORDER_FALLBACKS = ((10, 10), (12, 12), (6, 6))


def anchors_on(anchor_k: Any) -> bool:
    """True unless ``anchor_k`` asks for a plain ROM (None or an empty list)."""
    return anchor_k is not None and not (isinstance(anchor_k, list | tuple | np.ndarray) and len(anchor_k) == 0)


def tsd_n_steps(n_inputs: int, na: int, nb: int, dt_star: float) -> int:
    """Record length (steps) of a TSD training half: 16 samples per ARX parameter per output (as for the UVLM;
    8 left the validation error of an 8-shape basis at 4-14 %), >= 60 t*, even."""
    n = max(16 * n_inputs * (na + nb), int(math.ceil(60.0 / dt_star)))
    return n + (n % 2)


def tsd_grid_spec(grid_scale: float = 1.0) -> GridSpec:
    """The default TSD grid with every cell count multiplied by ``grid_scale``."""
    check_number("grid_scale", grid_scale, 0.25, strict=False, upper=4.0, upper_strict=False)
    return GridSpec().scaled(grid_scale) if grid_scale != 1.0 else GridSpec()


def check_tsd_settings(n_shapes: int | None = None, *, thickness_form: str | None = None,
                       thickness_to_chord: float = 0.0, grid_scale: float = 1.0, tsd_dt: float = 0.02,
                       coefficients: str = "ames", symmetry: str | None = None, low_k_corner: float = 0.0,
                       k_max: float = 1.5, anchor_k: Sequence[float] | None = DEFAULT_ANCHOR_K,
                       anchor_hold: float = STEP_HOLD, supercritical_refine: float | None = SUPERCRITICAL_REFINE,
                       validation_band: float | None = TSD_VALIDATION_BAND, **_: Any) -> None:
    """Validate TSD training settings (InputError naming the field); ``n_shapes`` also checks the grid size."""
    check_thickness(thickness_form, thickness_to_chord)
    check_supercritical_refine(supercritical_refine)
    if symmetry is not None:
        image_sign(symmetry)
    spec = tsd_grid_spec(grid_scale)
    if coefficients not in COEFFICIENT_SETS:
        raise InputError("coefficients", f"must be one of {COEFFICIENT_SETS}, got {coefficients!r}")
    if not (isinstance(tsd_dt, int | float) and math.isfinite(tsd_dt) and 0.0 < tsd_dt <= 0.05):
        raise InputError("tsd_dt", f"must be in (0, 0.05] (t*; larger steps are unstable), got {tsd_dt!r}")
    check_number("k_max", k_max, 0.0)
    check_number("low_k_corner", low_k_corner, 0.0, strict=False, upper=float(k_max), upper_strict=False)
    check_validation_band(validation_band, float(k_max))
    if anchors_on(anchor_k):
        check_anchor_k(cast(Sequence[float], anchor_k), float(k_max))
        check_anchor_hold(anchor_hold)
    if n_shapes is not None:
        columns = spec.n_chord * spec.n_span
        if columns < MIN_WING_COLUMNS_PER_SHAPE * n_shapes:
            raise InputError("grid_scale", f"the grid has {columns} wing node columns, too coarse for {n_shapes} "
                             f"shapes (need {MIN_WING_COLUMNS_PER_SHAPE} per shape); raise grid_scale")


def make_tsd_solver(thickness_form: str | None = None, thickness_to_chord: float = 0.0, grid_scale: float = 1.0,
                    tsd_dt: float = 0.02, coefficients: str = "ames") -> TsdSolver:
    """A TSD solver for a wing section (None: flat plate) on the default grid scaled by ``grid_scale``."""
    check_tsd_settings(thickness_form=thickness_form, thickness_to_chord=thickness_to_chord,
                       grid_scale=grid_scale, tsd_dt=tsd_dt, coefficients=coefficients)
    return TsdSolver(thickness_form=thickness_form, thickness_to_chord=thickness_to_chord,
                     grid=tsd_grid_spec(grid_scale), dt=tsd_dt, coefficients=coefficients)


def train_tsd_rom(
    mesh: StandardMesh,
    shapes: np.ndarray,
    mach: float,
    solver: TsdSolver | None = None,
    na: int = TSD_ORDERS[0],
    nb: int = TSD_ORDERS[1],
    *,
    thickness_form: str | None = None,
    thickness_to_chord: float = 0.0,
    grid_scale: float = 1.0,
    tsd_dt: float = 0.02,
    coefficients: str = "ames",
    dt_star: float = 0.1,
    n_steps: int | None = None,
    k_max: float = 1.5,
    displacement_fraction: float = 0.002,
    seed: int = 0,
    nrmse_tol: float = 0.05,
    reduce_order: int | str | None = "auto",
    linearity_check: bool = False,
    progress: ProgressFn | None = None,
    symmetry: str | None = None,
    low_k_corner: float = 0.0,
    anchor_k: Sequence[float] | None = DEFAULT_ANCHOR_K,
    anchor_hold: float = STEP_HOLD,
    supercritical_refine: float | None = SUPERCRITICAL_REFINE,
    validation_band: float | None = TSD_VALIDATION_BAND,
) -> TrainedRom:
    """ARX ROM of the TSD solver for shapes [N, m] (m) at ``mach`` about the steady mean flow of the section.

    ``linearity_check``: run the training signal again at half amplitude and store the relative deviation from
    linear scaling of the GAC at k <= validation_band (``linearity_error``; a warning above 2 %). Costs one more
    unsteady run.
    ``nrmse_tol`` is 5 % (the UVLM's is 2 %): at high subsonic Mach the compressible response has a long memory
    (slow upstream acoustic waves) that an ARX of order 8 free-runs to 1.5-3 % on an 8-shape basis (measured on
    the cropped delta at M 0.87); above 2 % the ROM carries a warning. The default orders are ``TSD_ORDERS``
    (8/8); 12/12 (a record 1.5 times longer, ``tsd_n_steps``) is asked for with na/nb.
    ``symmetry``: the root plane's (symmetric, antisymmetric, none: a free wing; ``TsdSolver.symmetry``); None
    keeps the solver's.
    ``anchor_k`` (reduced frequencies on c_ref / 2; default ``DEFAULT_ANCHOR_K``): after the training run, each
    shape is stepped alone and held ``anchor_hold`` t* (``anchors.step_anchors``, one record per shape side by
    side), and the ROM gets the parallel lag correction that reproduces the direct transfer matrix at those k
    exactly (``anchors.anchored``; (2 K - 1) m more states for K anchors). The same records check the anchored ROM
    over ``ANCHOR_BAND_K`` (``anchor_band_error``). Costs about 2.3 training runs for 8 shapes; pins the low-k GAF
    that decides transonic ROM-AMS flutter (docs/transonic.md 7.7, 7.11). None or [] trains a plain ROM, which
    carries ``UNANCHORED_WARNING`` (7.10).
    ``supercritical_refine`` (default ``SUPERCRITICAL_REFINE``, 1.5): when the steady mean flow on the requested grid
    is supercritical, the ROM is trained on that grid with every cell count multiplied by this (the coarse grid's
    first-order supersonic region puts the flutter speed up to 6 % high, docs/transonic.md 7.20, 7.21); None keeps
    the requested grid, and the ROM carries ``SUPERCRITICAL_WARNING``.
    ``validation_band`` (default ``TSD_VALIDATION_BAND``, k 3; None: the whole record): the validation NRMSE counts
    the records at k <= it only (``train_rom``), and the ROM reports the share above it (``validation_distortion``).
    """
    shapes = np.asarray(shapes, dtype=float)
    m = shapes.shape[1] if shapes.ndim == 2 else 1
    check_tsd_settings(m, thickness_form=thickness_form, thickness_to_chord=thickness_to_chord,
                       grid_scale=grid_scale, tsd_dt=tsd_dt, coefficients=coefficients, symmetry=symmetry,
                       low_k_corner=low_k_corner, k_max=k_max, anchor_k=anchor_k, anchor_hold=anchor_hold,
                       supercritical_refine=supercritical_refine, validation_band=validation_band)
    anchor = anchors_on(anchor_k)
    solver = solver or make_tsd_solver(thickness_form, thickness_to_chord, grid_scale, tsd_dt, coefficients)
    solver = cast(TsdSolver, with_symmetry(solver, symmetry))  # replaced before the run: its mean flow is read below
    solver, refined = refined_for_mean_flow(solver, mesh, mach, check_supercritical_refine(supercritical_refine),
                                            _scaled(progress, 0.0, 0.02))
    if n_steps is None:
        n_steps = tsd_n_steps(m, na, nb, dt_star)
    share = 0.3 if anchor else 1.0
    rom = train_rom(mesh, shapes, mach, solver, na=na, nb=nb, k_max=k_max, n_steps=n_steps, dt_star=dt_star,
                    seed=seed, nrmse_tol=nrmse_tol, reduce_order=reduce_order, progress=_scaled(progress, 0.0, share),
                    displacement_fraction=displacement_fraction, order_fallbacks=ORDER_FALLBACKS,
                    low_k_corner=low_k_corner, validation_band=validation_band)
    rom.solver = "tsd"
    worst = float(np.max(rom.validation_nrmse))
    if worst > 0.02:
        rom.warnings.append(f"validation NRMSE {100 * worst:.1f} % (> 2 %): ARX of order {rom.na}/{rom.nb} on the "
                            "TSD's long-memory compressible response")
    if solver.last_mean_flow is not None:
        rom.mean_flow = _mean_flow_dict(solver)
        if refined is not None:
            rom.warnings.append(refined)
        elif (supercritical := supercritical_warning(solver.last_mean_flow)) is not None:
            rom.warnings.append(supercritical)
        if not solver.last_mean_flow.steady.converged:
            steady = solver.last_mean_flow.steady
            rom.warnings.append(f"TSD mean flow not converged to dphi/dt < {solver.steady_tol:g} in "
                                f"{steady.steps} steps ({steady.steps * solver.last_mean_flow.dt:g} t*)")
    if anchor:
        k = check_anchor_k(cast(Sequence[float], anchor_k), k_max)
        band = np.asarray(ANCHOR_BAND_K)
        gaf = step_anchors(solver, mesh, shapes, mach, np.concatenate([k, band]), dt_star, displacement_fraction,
                           anchor_hold, _scaled(progress, share, 1.0 - share))
        try:
            _anchor(rom, k, gaf[:k.size], band, gaf[k.size:])
        except TrainingError as exc:  # the step records contradict the training records: keep the plain ROM
            _keep_plain(rom, str(exc), band, gaf[k.size:])
    else:
        rom.warnings.append(UNANCHORED_WARNING)
    if solver.step_halvings and solver.last_mean_flow is not None:
        rom.mean_flow = _mean_flow_dict(solver)  # the last run's step
        rom.warnings.append(f"the TSD march diverged at the capped step and was repeated with it halved "
                            f"{solver.step_halvings} time(s), to dt {solver.last_mean_flow.dt:.4g} t*")
    if linearity_check:
        half = solver.simulate(mesh, shapes, 0.5 * rom.signals_train, mach, dt_star)
        full = rom.gac_train
        if validation_band is not None:  # what the ROM models: the response in the band the validation counts
            half, full = band_part(half, dt_star, validation_band), band_part(full, dt_star, validation_band)
        rom.linearity_error = float(np.linalg.norm(2.0 * half - full) / np.linalg.norm(full))
        if rom.linearity_error > LINEARITY_TOL:
            rom.warnings.append(f"GAC scale nonlinearly with amplitude: {100 * rom.linearity_error:.1f} % "
                                f"(> {100 * LINEARITY_TOL:.0f} %); reduce displacement_fraction")
    return rom


def _mean_flow_dict(solver: TsdSolver) -> dict[str, Any]:
    """The solver's last mean flow as the ROM stores it, with the grid it was solved on (cell counts, extents)."""
    assert solver.last_mean_flow is not None
    return {**solver.last_mean_flow.to_dict(), "grid": asdict(solver.grid)}


#: the warning of a ROM whose anchored model missed the validation tolerance: the plain ROM is kept
CONTRADICT_WARNING = ("the step records contradict the training records ({reason}); the plain ROM is kept, "
                      "{band_error:.2f} % of the largest entry off the step records at k = {k_worst:g} (checked at "
                      "k {k_lo:g}-{k_hi:g}); measured on AGARD 445.6 at M 0.96 on the grid x 1.5 (supercritical): "
                      "the plain ROM 1.2 % below the step records' own flutter point, docs/transonic.md 7.21")


def _band_error(ss: Any, band: np.ndarray, band_gaf: np.ndarray) -> np.ndarray:
    """Largest error [n_band] of the model's transfer matrix against the direct one at each k of ``band``, as a
    share of that k's largest direct entry."""
    return np.abs(ss.freqresp(band) - band_gaf).max(axis=(1, 2)) / np.abs(band_gaf).max(axis=(1, 2))


def _keep_plain(rom: TrainedRom, reason: str, band: np.ndarray, band_gaf: np.ndarray) -> None:
    """After ``_anchor`` refused the anchors: the plain ROM stays, with its error against the step records over
    ``band`` stored (``anchor_band_error``) and both warnings (``CONTRADICT_WARNING``, ``UNANCHORED_WARNING``)."""
    err = _band_error(rom.ss, band, band_gaf)
    rom.anchor_band_error, rom.anchor_band_k, rom.anchor_band_gaf = float(err.max()), band, band_gaf
    rom.warnings.append(CONTRADICT_WARNING.format(reason=reason, band_error=100 * float(err.max()),
                                                  k_worst=float(band[int(np.argmax(err))]), k_lo=float(band[0]),
                                                  k_hi=float(band[-1])))
    rom.warnings.append(UNANCHORED_WARNING)


def _scaled(progress: ProgressFn | None, start: float, share: float) -> ProgressFn | None:
    """``progress`` for a part of the job: its fractions 0-1 mapped onto start .. start + share."""
    if progress is None:
        return None
    return lambda frac, msg: progress(start + share * frac, msg)


def _anchor(rom: TrainedRom, k: np.ndarray, gaf: np.ndarray, band: np.ndarray | None = None,
            band_gaf: np.ndarray | None = None) -> None:
    """Give ``rom`` the lag correction to the anchors (k, gaf [n_k, m, m]); its validation redone from rest, its
    error against the direct band_gaf [n_band, m, m] at ``band`` (share of the largest entry) stored.
    TrainingError when the anchored model misses the ROM's nrmse_tol (the anchors contradict the records)."""
    before = float(np.max(rom.validation_nrmse))
    fit = rom.ss.freqresp(k)
    ss = anchored(rom.ss, k, gaf)
    pred = ss.simulate(rom.signals_validation)
    val = rom.validation_error(pred)
    bad = [int(i) for i in np.flatnonzero(~(val <= rom.nrmse_tol))]
    if bad:
        raise TrainingError(f"anchored at k = {k.tolist()}: validation NRMSE above nrmse_tol = {rom.nrmse_tol:g} for "
                            + ", ".join(f"output {i}: {val[i]:.4f}" for i in bad), outputs=bad)
    rom.ss, rom.anchor_k, rom.anchor_gaf = ss, k, gaf
    rom.predicted_validation, rom.validation_nrmse = pred, val
    rom.spectral_radius = float(rom.ss.spectral_radius())
    change = float(np.abs(gaf - fit).max() / np.abs(gaf).max())
    rom.warnings.append(f"anchored to direct TSD runs at k = {', '.join(f'{x:g}' for x in k)}: correction up "
                        f"to {100 * change:.2f} % of the largest GAF entry there; validation NRMSE "
                        f"{100 * before:.2f} -> {100 * float(np.max(rom.validation_nrmse)):.2f} %")
    if band is None or band_gaf is None:
        return
    err = _band_error(ss, band, band_gaf)
    rom.anchor_band_error, rom.anchor_band_k, rom.anchor_band_gaf = float(err.max()), band, band_gaf
    if rom.anchor_band_error > ANCHOR_BAND_TOL:
        worst = float(band[int(np.argmax(err))])
        rom.warnings.append(f"anchored ROM off the direct TSD response by {100 * rom.anchor_band_error:.2f} % of "
                            f"the largest entry at k = {worst:g} (checked at k {band[0]:g}-{band[-1]:g}): add an "
                            "anchor there")
