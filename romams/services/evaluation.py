"""The one flutter-evaluation use case of romams: CLI, API workers and ``romams demo`` all call it.

It owns the defaults (flight condition, damping, number of modes, basis choice) and the JSON summary, so
the same structure gives the same numbers and the same keys wherever it is asked:

- structure: a design of the wing (modal analysis), its baseline, or external modes on the standard mesh;
- models: the wing's *active* basis (or one a request names) and the ROMs trained on it per Mach;
- condition: :class:`romams.services.flight.FlightCondition` (default constant-speed at ISA 10 km);
- damping: the wing's modal damping ratio (``WingDefinition.modal_damping``), applied everywhere;
- benchmark: the wing's baseline structure evaluated with the same models and condition (when it has one);
- fit: each mode's MAC in the basis; a structure below the basis' validated MAC is flagged with an
  estimated flutter-speed error.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from romams.persistence import content_hash
from romams.serialize import to_jsonable
from romams.services.errors import InvalidInput, from_input_error
from romams.services.flight import DEFAULT_CONDITION, FlightCondition
from romams_core.errors import InputError

DEFAULT_N_MODES = 4
#: Default basis criterion: every sample mode fitted with MAC >= 0.9999 (8 shapes on the cropped delta), the
#: criterion that keeps ROM-AMS within 1 % of ROM-PMS in flutter speed (docs/basis.md, tests).
DEFAULT_MAC_THRESHOLD = 0.9999
#: Estimated relative flutter-speed error of ROM-AMS per unit of the mode-fit residual sqrt(1 - MAC): the
#: generalized forces are linear in the shape, so the error is first order in the residual norm. Fitted to
#: the cropped-delta measurements (0.63 % max at hold-out MAC >= 0.9995, 4.5 % at MAC 0.98; docs/basis.md).
FIT_ERROR_PER_RESIDUAL = 0.30
#: Accuracy the default basis criterion was validated for (ROM-AMS vs ROM-PMS flutter speed).
VALIDATED_ERROR = 0.01


@dataclass(frozen=True)
class Models:
    """What one evaluation runs on: the wing, its standard mesh, a basis and the ROMs trained on it."""

    wing_id: int
    wing: Any  # romams_core.wing.WingDefinition
    mesh: Any  # romams_core.mesh.StandardMesh
    basis_id: int
    basis: Any  # romams_core.basis.Basis
    roms: Mapping[float, tuple[int, Any]]  # mach -> (rom_id, TrainedRom)

    @property
    def rom_ids(self) -> list[list[float]]:
        """[(mach, rom_id)] in Mach order (the identity of the models, e.g. for result caches)."""
        return [[float(m), int(self.roms[m][0])] for m in sorted(self.roms)]


def damping_ratio(wing: Any) -> float | None:
    """The wing's viscous modal damping ratio for flutter analyses (None: undamped)."""
    z = float(getattr(wing, "modal_damping", 0.0) or 0.0)
    return z if z > 0 else None


def structure_modal(models: Models, design: Any = None, modes: Any = None) -> Any:
    """ModalResult of the structure: ``modes`` (ExternalModes on the standard mesh), else a design, else the baseline.

    As many modes as the basis has per structure. InvalidInput naming ``design``/``modes``.
    """
    from romams_core.structure.modal import modal_analysis

    k = int(getattr(models.basis, "n_modes", 0) or DEFAULT_N_MODES)
    try:
        wing = models.wing
        if modes is not None:
            from romams_core.modes_io import wing_modal_result

            return wing_modal_result(modes, wing, models.mesh)
        if getattr(wing, "structure", True) is None:
            raise InvalidInput("modes", f"required: wing {wing.name!r} is planform-only (no built-in structure); "
                                        "give its modes")
        if design is None and wing.design_variables and not wing.has_baseline:
            raise InvalidInput("design", f"required: wing {wing.name!r} has no baseline structure")
        vec = None if design is None else np.asarray(wing.design_vector(design), dtype=float)
        return modal_analysis(wing, vec, n_modes=k, mesh=models.mesh)
    except (InputError, ValueError) as exc:
        if isinstance(exc, InvalidInput):
            raise
        raise from_input_error(exc, "modes" if modes is not None else "design") from exc


def evaluate(models: Models, modal: Any, condition: FlightCondition = DEFAULT_CONDITION, *,
             benchmark: Any = None, own_modes: bool = False) -> Any:
    """StructureEvaluation of ``modal`` with ``models`` under ``condition`` (``benchmark``: an Envelope or None).

    ``own_modes`` (ROM-PMS): the ROMs were trained on this structure's own modes, so its shapes are the basis.
    """
    return evaluate_many(models, [modal], condition, benchmark=benchmark,
                         shapes=modal.shapes if own_modes else None)[0]


def projection_choice(condition: FlightCondition, roms: Mapping[float, tuple[int, Any]]) -> str:
    """none | dlm for ROM-AMS with ``roms`` ({mach: (id, TrainedRom)}): "auto" adds the DLM residual to TSD ROMs,
    where an exact ROM-AMS was measured 1.3 % above the TSD's own flutter point (docs/transonic.md 7.12), and not
    to the linear solvers' ROMs, whose default basis stays within 0.3 % (and whose evaluations must stay fast)."""
    if condition.projection_correction != "auto":
        return condition.projection_correction
    solvers = {str(getattr(rom, "solver", "")) for _, rom in roms.values()}
    return "dlm" if solvers == {"tsd"} else "none"


def evaluate_many(models: Models, modals: Sequence[Any], condition: FlightCondition = DEFAULT_CONDITION, *,
                  benchmark: Any = None, shapes: Any = None, vg_checks: bool = True) -> list[Any]:
    """StructureEvaluations of several structures with the basis ROMs of ``models``, their flutter searches run as
    one batch per Mach (``romams_core.evaluate.evaluate_structures``; equal to one-at-a-time evaluations).

    ``shapes``: the basis the ROMs were trained on (default the models' basis; given: the structure's own modes,
    which need no projection correction); ``vg_checks``: as ``evaluate_designs``. InvalidInput naming the field.
    """
    from romams_core.evaluate import evaluate_structures
    from romams_core.projection_residual import ResidualCorrection

    roms = {float(m): r for m, (_, r) in models.roms.items()}
    residual = None
    if shapes is None and projection_choice(condition, models.roms) == "dlm":
        residual = ResidualCorrection(models.mesh, getattr(models.wing, "symmetry", "symmetric"))
    try:
        return evaluate_structures(modals, models.basis.shapes if shapes is None else shapes, roms,
                                   sweep=condition.sweep, coupling=condition.coupling,
                                   zeta=damping_ratio(models.wing), benchmark=benchmark,
                                   mac_threshold=float(models.basis.mac_threshold),
                                   flutter_options={**condition.flutter_options(), "vg_checks": vg_checks},
                                   residual=residual)
    except InputError as exc:
        raise from_input_error(exc) from exc


def evaluate_designs_summary(models: Models, designs: Sequence[Any], *,
                             condition: FlightCondition = DEFAULT_CONDITION,
                             cache: Callable[[tuple[Any, ...], Callable[[], Any]], Any] | None = None,
                             ) -> list[dict[str, Any]]:
    """The use case for a chunk of designs: the JSON summary of each (as ``evaluate_structure_summary``), or
    {"error": message} for a design that is rejected (:func:`evaluate_designs` without the full results, so without
    the checks of the V-g curves after the crossing)."""
    return [s for s, _ in evaluate_designs(models, designs, condition=condition, cache=cache, vg_checks=False)]


def evaluate_designs(models: Models, designs: Sequence[Any], *, condition: FlightCondition = DEFAULT_CONDITION,
                     cache: Callable[[tuple[Any, ...], Callable[[], Any]], Any] | None = None,
                     vg_checks: bool = True) -> list[tuple[dict[str, Any], Any]]:
    """(JSON summary, StructureEvaluation or None) of each design of a chunk; a rejected design gets
    ({"error": message}, None). Modal analysis per design; the flutter searches of all designs at each Mach run as
    one batch. Should the batch fail, the designs are evaluated one at a time, so that the error is reported for the
    design that caused it. ``vg_checks`` False: the V-g curves after each crossing are not checked by full solves
    (the flutter points are the same; for evaluations whose curves are not kept, docs/performance.md 6c).
    """
    try:
        base = baseline_evaluation(models, condition, cache)
    except ValueError as exc:  # the benchmark of every design: each reports it
        return [({"error": str(exc)}, None) for _ in designs]
    bench = None if base is None else base.envelope
    out: list[tuple[dict[str, Any], Any]] = [({}, None) for _ in designs]
    modals, idx = [], []
    for i, d in enumerate(designs):
        try:
            modals.append(structure_modal(models, d, None))
            idx.append(i)
        except ValueError as exc:  # a design the structure model rejects: reported per design
            out[i] = ({"error": str(exc)}, None)
    try:
        results = evaluate_many(models, modals, condition, benchmark=bench, vg_checks=vg_checks)
    except ValueError:
        results = []
        for modal in modals:
            try:
                results.append(evaluate_many(models, [modal], condition, benchmark=bench, vg_checks=vg_checks)[0])
            except ValueError as exc:
                results.append(exc)
    for i, r in zip(idx, results, strict=True):
        out[i] = ({"error": str(r)}, None) if isinstance(r, Exception) else (summarize(r, models, condition), r)
    return out


def baseline_evaluation(models: Models, condition: FlightCondition = DEFAULT_CONDITION,
                        cache: Callable[[tuple[Any, ...], Callable[[], Any]], Any] | None = None) -> Any:
    """The wing's baseline structure evaluated with the same models and condition (None: no baseline).

    ``cache(key, load)`` memoizes it (a worker's object cache); without it the baseline is evaluated now.
    """
    if not getattr(models.wing, "has_baseline", False):
        return None

    def load() -> Any:
        return evaluate(models, structure_modal(models, None), condition)

    key = ("baseline", models.wing_id, models.basis_id, tuple(map(tuple, models.rom_ids)),
           tuple(sorted(condition.to_json().items())))
    return cache(key, load) if cache is not None else load()


def evaluate_structure_summary(models: Models, *, design: Any = None, modes: Any = None,
                               condition: FlightCondition = DEFAULT_CONDITION, method: str = "rom-ams",
                               cache: Callable[[tuple[Any, ...], Callable[[], Any]], Any] | None = None,
                               ) -> tuple[dict[str, Any], Any]:
    """The use case: evaluate one structure (design / baseline / external modes) -> (JSON summary, result)."""
    modal = structure_modal(models, design, modes)
    base = baseline_evaluation(models, condition, cache)
    result = evaluate(models, modal, condition, benchmark=None if base is None else base.envelope)
    summary = summarize(result, models, condition, method=method, external=modes is not None)
    return summary, result


def pms_summary(models: Models, modal: Any, own_roms: Mapping[float, tuple[int, Any]],
                condition: FlightCondition = DEFAULT_CONDITION, *, external: bool = False,
                cache: Callable[[tuple[Any, ...], Callable[[], Any]], Any] | None = None) -> tuple[dict[str, Any], Any]:
    """ROM-PMS reference of a structure: ROMs trained on its own modes (``own_roms``: mach -> (id, rom)).

    The benchmark envelope is still the baseline evaluated with the basis models (as for ROM-AMS).
    """
    base = baseline_evaluation(models, condition, cache)
    pms = Models(models.wing_id, models.wing, models.mesh, models.basis_id, models.basis, own_roms)
    result = evaluate(pms, modal, condition, benchmark=None if base is None else base.envelope, own_modes=True)
    return summarize(result, pms, condition, method="rom-pms", external=external), result


#: Bumped when the evaluation of stored models changes. 2 (2026-12-04): ARX ROMs stored with their full realization
#: are loaded with their minimal one (docs/transonic.md 7.9); results computed on the full one may be wrong.
EVALUATION_VERSION = 2


def evaluation_key(wing_id: int, basis_id: int, rom_ids: Any, condition: Mapping[str, Any], design: Any) -> str:
    """Content hash of one design's evaluation (same inputs, same summary): the API's stored-evaluation lookup and
    the workers' result cache use it. ``EVALUATION_VERSION`` is part of it, so results stored before a change of
    how stored models are evaluated are not served again."""
    return content_hash("flutter", EVALUATION_VERSION, wing_id, basis_id, rom_ids, dict(condition), design)


def fit_error_estimate(min_mac: float) -> float:
    """Estimated relative ROM-AMS flutter-speed error (fraction) of a structure whose worst mode fits with min_mac."""
    return FIT_ERROR_PER_RESIDUAL * math.sqrt(max(0.0, 1.0 - float(min_mac)))


def _f(x: Any) -> float | None:
    """Finite float or None."""
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


def result_row(r: Any, env: Any = None, rom_id: int | None = None, rom: Any = None) -> dict[str, Any]:
    """JSON row of one Mach's FlutterResult (speeds in m/s: true airspeed and EAS; q in Pa; omega in rad/s).

    ``rom`` (the ROM the result came from) names the aerodynamic solver and carries its warnings.
    """
    idx = np.array([], dtype=int)
    if env is not None:
        idx = np.flatnonzero(np.isclose(np.asarray(env.mach, dtype=float), float(r.mach), rtol=0, atol=1e-9))
    omega = _f(r.omega_flutter_rad_s)
    return {
        "mach": float(r.mach),
        "flutter_found": bool(r.flutter_found),
        "v_flutter_m_s": _f(r.v_flutter_m_s),
        "v_true_m_s": _f(r.v_true_m_s),
        "v_eas_m_s": _f(r.v_eas_m_s),
        "q_flutter_pa": _f(r.q_flutter_pa),
        "omega_flutter_rad_s": omega,
        "frequency_hz": None if omega is None else omega / (2.0 * math.pi),
        "k_flutter": _f(r.k_flutter),
        "flutter_mode": None if r.flutter_mode is None else int(r.flutter_mode),
        "sdoff": bool(r.sdoff),
        "outside_band": bool(getattr(r, "outside_band", False)),
        "unstable_above_band_v_m_s": _f(getattr(r, "unstable_above_band_v_m_s", None)),
        "altitude_m": _f(r.altitude_m),
        "sweep": r.sweep,
        "coupling": r.coupling,
        "altitude_ref_m": _f(r.altitude_ref_m),
        "rho_ref_kg_m3": _f(r.rho_ref),
        "a_ref_m_s": _f(r.a_ref),
        "rom_id": rom_id,
        "solver": getattr(rom, "solver", None),
        "aero_warnings": [str(w) for w in getattr(rom, "warnings", [])],
        "safe_altitude_m": _f(env.safe_altitude_m[idx[0]]) if idx.size else None,
        "envelope_status": env.status[idx[0]] if idx.size else None,
        "message": r.message,
    }


def _rom_entry(models: Models, mach: float) -> tuple[int | None, Any]:
    """(rom_id, rom) of a Mach's ROM in ``models`` ((None, None) when absent)."""
    entry = models.roms.get(float(mach))
    return (None, None) if entry is None else (int(entry[0]), entry[1])


def summarize(result: Any, models: Models, condition: FlightCondition = DEFAULT_CONDITION, *,
              method: str = "rom-ams", external: bool = False) -> dict[str, Any]:
    """The JSON summary of a StructureEvaluation: the same keys from the CLI, the API and in-process calls."""
    env, comp = result.envelope, result.comparison
    mass = _f(result.mass_kg)
    min_mac = float(result.min_mac)
    est = fit_error_estimate(min_mac) if method == "rom-ams" else 0.0
    fit_ok = bool(result.mac_ok)
    applied = projection_choice(condition, models.roms) if method == "rom-ams" else "none"
    rows = [result_row(r, env, *_rom_entry(models, r.mach)) for r in result.flutter]
    out = {
        "wing": models.wing.name,
        "wing_id": int(models.wing_id),
        "method": method,
        "basis_id": int(models.basis_id),
        "n_basis": int(models.basis.n_basis),
        "mac_threshold": float(models.basis.mac_threshold),
        "flight_condition": {**condition.to_json(), "projection_correction_applied": applied,
                             "damping_ratio": damping_ratio(models.wing) or 0.0,
                             "speeds": "v_flutter_m_s = v_true_m_s: true airspeed at the flutter point; "
                                       "v_eas_m_s: equivalent airspeed at ISA sea-level density"},
        "mass_kg": None if external and not (mass and mass > 0) else mass,
        "frequencies_hz": np.asarray(result.frequencies_hz, dtype=float),
        "mac": np.asarray(result.mac, dtype=float),
        "min_mac": min_mac,
        "mac_ok": fit_ok,
        "fit_error_estimate_pct": 100.0 * est,
        "sdoff": bool(result.sdoff),
        "results": rows,
        "envelope_ok": None if comp is None else bool(comp.envelope_ok),
        "envelope_margin_m": None if comp is None else np.asarray(comp.margin_m, dtype=float),
        "constraints_ok": bool(result.constraints_ok),
        "message": result.message,
        "warning": None,
    }
    if method == "rom-ams" and (not fit_ok or est > VALIDATED_ERROR):
        # the modes below the basis threshold, or whose own estimate exceeds the validated accuracy
        limit = max(float(models.basis.mac_threshold), 1.0 - (VALIDATED_ERROR / FIT_ERROR_PER_RESIDUAL) ** 2)
        bad = [i + 1 for i, m in enumerate(np.asarray(result.mac)) if m < limit]
        out["warning"] = (f"modes {bad} fit the basis with MAC < {limit:.6g} (worst "
                          f"{min_mac:.5f}): estimated flutter-speed error {100.0 * est:.1f} % (the basis was "
                          f"validated for {100.0 * VALIDATED_ERROR:g} %); "
                          + ("the DLM projection residual is added (projection_correction dlm)"
                             if applied == "dlm" else
                             "verify with method rom-pms, or add the DLM projection residual "
                             "(projection_correction dlm)"))
    return to_jsonable(out)
