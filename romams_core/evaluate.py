"""Flutter evaluation of one structure with stored ROM-AMS models (one per Mach number).

Steps: project the structure's mode shapes on the basis (gamma [m, k], MAC per mode), turn each
basis-coordinate ROM into real modal coordinates (u = gamma xi, F = gamma^T f), run the flutter search
at every Mach, build the safe envelope and compare it with a benchmark envelope when one is given.
Constraints as in the ROM-AMS paper: envelope not above the benchmark at any Mach, no SDOFF, every
mode fitted with MAC >= mac_threshold.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from romams_core.basis import project
from romams_core.envelope import (
    DEFAULT_ALTITUDE_RANGE_M,
    DEFAULT_MARGIN,
    Envelope,
    EnvelopeComparison,
    compare_envelopes,
    envelope_from_results,
)
from romams_core.errors import InputError
from romams_core.flutter import FlutterResult, flutter_batch
from romams_core.projection_residual import ResidualCorrection
from romams_core.statespace import to_modal


@dataclass
class StructureEvaluation:
    """Flutter evaluation of one structure (SI units; frequencies in Hz, flutter data per Mach)."""

    mass_kg: float
    frequencies_hz: np.ndarray  # [k]
    mac: np.ndarray  # [k] fit MAC of each mode in the basis
    min_mac: float
    mac_ok: bool
    machs: np.ndarray  # [n]
    flutter: list[FlutterResult]  # one per Mach, same order as machs
    envelope: Envelope
    comparison: EnvelopeComparison | None
    sdoff: bool  # SDOFF at any Mach
    constraints_ok: bool  # mac_ok and not sdoff and (envelope_ok when a benchmark was given)
    message: str


#: The sweep used at Mach 0 whatever was asked: a constant speed M a or a Mach-matched altitude is undefined there.
INCOMPRESSIBLE_SWEEP = "constant-density"


def _rom_parts(rom: Any, mach: float) -> tuple[Any, float]:
    """(DiscreteSS in basis coordinates, c_ref m) of a ROM entry (TrainedRom-like or a (ss, c_ref) pair)."""
    if hasattr(rom, "ss") and hasattr(rom, "c_ref"):
        return rom.ss, float(rom.c_ref)
    if isinstance(rom, tuple) and len(rom) == 2:
        return rom[0], float(rom[1])
    raise InputError(f"roms[{mach}]", f"needs .ss and .c_ref (a trained ROM), got {type(rom).__name__}")


def evaluate_structure(modal: Any, basis_shapes: np.ndarray, roms: Mapping[float, Any],
                       **options: Any) -> StructureEvaluation:
    """Evaluate a structure (``modal``: .omega [k] rad/s, .shapes [N, k], .mass_kg) with ROMs {mach: rom}.

    ``basis_shapes`` [N, m] are the basis the ROMs were trained on; ``options`` are the keywords of
    ``evaluate_structures`` (sweep, coupling, zeta, mac_threshold, benchmark, margin, altitude_range_m,
    flutter_options, residual). The batch of one. Returns a StructureEvaluation.
    """
    return evaluate_structures([modal], basis_shapes, roms, **options)[0]


def evaluate_structures(
    modals: Sequence[Any],
    basis_shapes: np.ndarray,
    roms: Mapping[float, Any],
    *,
    sweep: str = "constant-speed",
    coupling: str = "tustin",
    zeta: np.ndarray | float | None = None,
    mac_threshold: float = 0.98,
    benchmark: Envelope | None = None,
    margin: float = DEFAULT_MARGIN,
    altitude_range_m: tuple[float, float] = DEFAULT_ALTITUDE_RANGE_M,
    flutter_options: Mapping[str, Any] | None = None,
    residual: ResidualCorrection | None = None,
) -> list[StructureEvaluation]:
    """Evaluate structures (each: .omega [k] rad/s, .shapes [N, k], .mass_kg) with ROMs {mach: rom}, together.

    ``basis_shapes`` [N, m] are the basis the ROMs were trained on; ``flutter_options`` go to the flutter
    search (e.g. altitude_ref_m, q_max, n_points). At every Mach the searches of all structures run as one
    batch (``flutter_batch``: one stacked eigen-solve per sweep step); the results equal one-at-a-time
    evaluations. Mach 0 (incompressible) always uses the constant-density sweep and is left out of the flight
    envelope. ``residual``: add the modes' part outside the basis span by the DLM (``projection_residual``).
    Returns one StructureEvaluation per structure, in order.
    """
    if not roms:
        raise InputError("roms", "need at least one Mach number")
    inputs = [_structure_inputs(m, basis_shapes, mac_threshold) for m in modals]
    opts = dict(flutter_options or {})
    for key in ("sweep", "coupling", "zeta"):
        if key in opts:
            raise InputError("flutter_options", f"pass {key!r} as a keyword of evaluate_structure")
    machs = sorted(float(m) for m in roms)
    by_mach = {float(m): r for m, r in roms.items()}
    per_mach: list[list[FlutterResult]] = []
    for mach in machs:
        ss, c_ref = _rom_parts(by_mach[mach], mach)
        sweep_m = INCOMPRESSIBLE_SWEEP if mach == 0.0 else sweep  # no constant speed or Mach-matched flight at M 0
        kw = dict(opts, altitude_range_m=opts.get("altitude_range_m", altitude_range_m)) if sweep_m == "matched" \
            else opts
        k_band = getattr(by_mach[mach], "k_max", None)  # the identified band, when the ROM carries it
        designs = [(om, to_modal(ss, proj.gamma)) for om, _, proj in inputs]
        if residual is not None:
            designs = [(om, residual.apply(ss_m, np.asarray(m.shapes, dtype=float), inp[2].fitted, mach))
                       for (om, ss_m), m, inp in zip(designs, modals, inputs, strict=True)]
        per_mach.append(flutter_batch(designs, c_ref, mach, sweep=sweep_m, coupling=coupling, zeta=zeta,
                                      k_band=None if k_band is None else float(k_band), **kw))
    return [_assemble(inputs[i], machs, [r[i] for r in per_mach], benchmark, margin, altitude_range_m,
                      mac_threshold) for i in range(len(inputs))]


def _structure_inputs(modal: Any, basis_shapes: np.ndarray, mac_threshold: float) -> tuple[np.ndarray, float, Any]:
    """(omega [k] rad/s, mass kg, projection on the basis) of a structure; InputError naming the field."""
    omega = np.asarray(getattr(modal, "omega", None), dtype=float)
    shapes = np.asarray(getattr(modal, "shapes", None), dtype=float)
    if omega.ndim != 1 or omega.size == 0:
        raise InputError("modal.omega", "must be a 1-D array of circular frequencies (rad/s)")
    if shapes.ndim != 2 or shapes.shape[1] != omega.size:
        raise InputError("modal.shapes", f"must be [N, {omega.size}], got {shapes.shape}")
    return omega, float(getattr(modal, "mass_kg", math.nan)), project(basis_shapes, shapes, mac_threshold)


def _assemble(inputs: tuple[np.ndarray, float, Any], machs: list[float], results: list[FlutterResult],
              benchmark: Envelope | None, margin: float, altitude_range_m: tuple[float, float],
              mac_threshold: float) -> StructureEvaluation:
    """StructureEvaluation of one structure from its flutter results per Mach (envelope, comparison, constraints)."""
    omega, mass, proj = inputs
    flying = [r for r in results if r.mach > 0.0]  # Mach 0 (incompressible) has no flight envelope
    env = envelope_from_results(flying, margin, altitude_range_m) if flying else Envelope(
        np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0), [], float(margin), np.asarray(altitude_range_m, float))
    comp = compare_envelopes(env, benchmark) if benchmark is not None else None
    sdoff = any(r.sdoff for r in results)
    ok = proj.ok and not sdoff and (comp is None or comp.envelope_ok)
    notes = []
    if not proj.ok:
        bad = [i + 1 for i, f in enumerate(proj.poor_fit) if f]
        notes.append(f"modes {bad} fit the basis with MAC < {mac_threshold:g}")
    if sdoff:
        notes.append("single-degree-of-freedom flutter at Mach " + ", ".join(f"{r.mach:g}" for r in results if r.sdoff))
    if comp is not None and not comp.envelope_ok:
        notes.append("envelope above the benchmark at Mach " + ", ".join(
            f"{m:g}" for m, o in zip(comp.mach, comp.ok, strict=True) if not o))
    return StructureEvaluation(
        mass_kg=mass,
        frequencies_hz=omega / (2.0 * math.pi),
        mac=np.asarray(proj.mac, dtype=float),
        min_mac=float(proj.min_mac),
        mac_ok=bool(proj.ok),
        machs=np.asarray(machs),
        flutter=results,
        envelope=env,
        comparison=comp,
        sdoff=bool(sdoff),
        constraints_ok=bool(ok),
        message="; ".join(notes) if notes else "all constraints satisfied",
    )
