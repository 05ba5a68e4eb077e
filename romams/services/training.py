"""Training of one aerodynamic ROM by solver name: the one dispatch the CLI, the demo, the API and the worker use.

Two kinds of solver stand behind the names:
- frequency-domain ("dlm", the default): generalized aerodynamic forces on a reduced-frequency table, fitted by
  a rational function approximation (``romams_core.training_rfa.train_rfa_rom``), a continuous ROM;
- time-domain ("uvlm", and the transonic "tsd"): a multisine march identified by ARX
  (``romams_core.training.train_rom``; ``romams_core.training_tsd.train_tsd_rom`` for the TSD, about its steady
  mean flow), a discrete ROM.

A ROM's identity (besides wing, basis and Mach) is ``{"solver", "na", "nb", "options"}``; the ARX orders are 0
for a frequency-domain solver, whatever was asked, so that equal requests find the same ROM.
"""

from __future__ import annotations

import importlib.util
import inspect
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

#: Solver of a new ROM when none is named.
DEFAULT_SOLVER = "dlm"
FREQUENCY_SOLVERS = ("dlm",)
TIME_SOLVERS = ("uvlm", "tsd")
SOLVERS = FREQUENCY_SOLVERS + TIME_SOLVERS
#: train-function arguments set by the service itself (not allowed in a request's ``options``)
RESERVED_OPTIONS = frozenset({"mesh", "shapes", "mach", "solver", "na", "nb", "progress"})


#: Name prefix of the ROMs fitted to imported GAF tables (``romams.services.gaf_import``): "external:<label>".
EXTERNAL_PREFIX = "external:"


def is_external(name: str) -> bool:
    """True for an imported (external) aerodynamic model, "external:<label>"."""
    return str(name).startswith(EXTERNAL_PREFIX)


def is_frequency_solver(name: str) -> bool:
    """True for a built-in frequency-domain solver (trained by an RFA)."""
    return name in FREQUENCY_SOLVERS


def available(name: str) -> bool:
    """True when the solver can run on this installation (the transonic solver is optional)."""
    if name == "tsd":
        return importlib.util.find_spec("romams_core.aero.tsd") is not None
    return name in SOLVERS


def make_solver(name: str) -> Any:
    """Aerodynamic solver by name: "dlm", "uvlm", or "tsd" once the transonic solver is installed."""
    if is_external(name):
        raise ValueError(f"solver: {name!r} is an imported GAF table, not a solver the service can run; import the "
                         f"table for this Mach first (romams train --gaf FILE --label {name[len(EXTERNAL_PREFIX):]}, "
                         "or POST /api/v1/wings/{wing}/roms/gaf)")
    if name == "dlm":
        from romams_core.aero.dlm import DlmSolver

        return DlmSolver()
    if name == "uvlm":
        from romams_core.aero.uvlm import UvlmSolver

        return UvlmSolver()
    if name == "tsd":
        try:
            from romams_core.aero.tsd import TsdSolver
        except ImportError as exc:
            raise ValueError("solver: the transonic small-disturbance solver is not available") from exc
        return TsdSolver()
    raise ValueError(f"solver: unknown solver {name!r} (available: {', '.join(s for s in SOLVERS if available(s))})")


def section_options(wing: Any) -> dict[str, Any]:
    """The wing's aerodynamic section for the TSD: its plate's airfoil thickness form, or a flat plate."""
    s = getattr(wing, "baseline", None) or getattr(wing, "structure", None)
    form = getattr(s, "thickness_form", "constant")
    if form in (None, "constant"):
        return {"thickness_form": None, "thickness_to_chord": 0.0}
    return {"thickness_form": str(form), "thickness_to_chord": float(s.thickness_to_chord)}


#: ARX orders (na, nb) of a UVLM ROM when a request names none
UVLM_ORDERS = (8, 8)


def default_orders(solver: str) -> tuple[int, int]:
    """ARX orders (na, nb) of ``solver`` when a request names none: the TSD's (``TSD_ORDERS``, 8/8), 8/8 for the
    UVLM, 0/0 for a frequency-domain or imported model."""
    if is_frequency_solver(solver) or is_external(solver):
        return 0, 0
    if solver == "tsd":
        from romams_core.training_tsd import TSD_ORDERS

        return TSD_ORDERS
    return UVLM_ORDERS


def rom_identity(solver: str = DEFAULT_SOLVER, na: int | None = None, nb: int | None = None,
                 options: Mapping[str, Any] | None = None, wing: Any = None) -> dict:
    """Identity of a trained ROM besides (wing, basis, Mach): the same dict the HTTP API stores.

    ``na``/``nb`` None: the solver's default orders (``default_orders``).

    For the TSD the wing's section (thickness form and t/c, ``section_options``), the default anchors
    (``DEFAULT_ANCHOR_K``), the supercritical grid refinement and the validation band are part of the identity
    unless the options name them; for every built-in solver (each models all three root conditions) a root symmetry
    other than symmetric (antisymmetric, or none: a free wing) is (a symmetric wing's identity names none, as
    before)."""
    if is_frequency_solver(solver) or is_external(solver):
        na = nb = 0  # an imported model is one per (wing, basis, Mach, label): importing again replaces it
    na = default_orders(solver)[0] if na is None else na
    nb = default_orders(solver)[1] if nb is None else nb
    opts = {} if is_external(solver) else dict(options or {})
    if solver == "tsd":  # the default anchors and grid refinement are part of the identity: a ROM stored without
        from romams_core.training_tsd import (  # them is not reused
            DEFAULT_ANCHOR_K,
            SUPERCRITICAL_REFINE,
            TSD_VALIDATION_BAND,
        )

        opts = {"anchor_k": list(DEFAULT_ANCHOR_K), "supercritical_refine": SUPERCRITICAL_REFINE,
                "validation_band": TSD_VALIDATION_BAND,
                **(section_options(wing) if wing is not None else {}), **opts}
        if opts["anchor_k"] is not None and len(opts["anchor_k"]) == 0:
            opts["anchor_k"] = None  # [] and null both ask for a plain ROM: one identity
    symmetry = getattr(wing, "symmetry", "symmetric") if wing is not None else "symmetric"
    if symmetry != "symmetric" and not is_external(solver):
        opts = {**opts, "symmetry": symmetry}
    return {"solver": str(solver), "na": int(na), "nb": int(nb), "options": dict(sorted(opts.items()))}


def train_function(solver: str) -> Callable[..., Any]:
    """The core training function of a solver's kind."""
    if is_frequency_solver(solver):
        from romams_core.training_rfa import train_rfa_rom

        return train_rfa_rom
    if solver == "tsd":
        from romams_core.training_tsd import train_tsd_rom

        return train_tsd_rom
    from romams_core.training import train_rom

    return train_rom


def allowed_options(solver: str) -> set[str]:
    """Names of the keyword settings a request may pass in ``options`` for ``solver``."""
    sig = inspect.signature(train_function(solver))
    names = {n for n, p in sig.parameters.items() if p.kind is p.KEYWORD_ONLY or p.default is not p.empty}
    return names - RESERVED_OPTIONS


def check_options(solver: str, options: Mapping[str, Any], n_shapes: int | None = None) -> None:
    """Validate the values of training settings before a job is queued (InvalidInput naming
    ``options.<name>``), with the core's own check (``check_rfa_settings`` for the dlm, ``check_tsd_settings``
    for the tsd, which also refuses a grid too coarse for ``n_shapes``; the UVLM trainer checks the rest as it
    starts, its ``symmetry`` here)."""
    if solver not in ("dlm", "tsd", "uvlm"):
        return
    from romams.services.errors import InvalidInput
    from romams_core.aero.protocol import image_sign
    from romams_core.errors import InputError
    from romams_core.training_rfa import check_rfa_settings
    from romams_core.training_tsd import check_tsd_settings

    try:
        if solver == "tsd":
            check_tsd_settings(n_shapes, **options)
        elif solver == "uvlm":
            if options.get("symmetry") is not None:
                image_sign(options["symmetry"])
        else:
            check_rfa_settings(**options)  # names already checked against allowed_options
    except InputError as exc:
        raise InvalidInput(f"options.{exc.field}", exc.reason) from None


def train(mesh: Any, shapes: Any, mach: float, ident: Mapping[str, Any],
          progress: Callable[[float, str], None] | None = None) -> Any:
    """Train the ROM of ``shapes`` [N, m] at ``mach`` with identity ``ident``: a TrainedRfaRom or a TrainedRom."""
    solver = str(ident["solver"])
    fn = train_function(solver)
    options = dict(ident.get("options") or {})
    if is_frequency_solver(solver):
        return fn(mesh, shapes, float(mach), make_solver(solver), progress=progress, **options)
    rom = fn(mesh, shapes, float(mach), None if solver == "tsd" else make_solver(solver), na=int(ident["na"]),
             nb=int(ident["nb"]), progress=progress, **options)
    if solver == "uvlm":  # flag shapes whose damping the lattice cannot resolve (the DLM as the independent check)
        from romams_core.aero.crosscheck import CHECK_K, uvlm_damping_warnings

        k = np.array([x for x in CHECK_K if x <= rom.k_max])  # within the ROM's excitation band
        if k.size:
            rom.warnings.extend(uvlm_damping_warnings(mesh, shapes, float(mach), rom.ss.freqresp(k), k,
                                                      symmetry=str(options.get("symmetry") or "symmetric")))
    return rom


def quality_line(rom: Any) -> str:
    """One-line quality of a trained ROM: the RFA's worst fit error, or the ARX ROM's validation NRMSE."""
    if hasattr(rom, "fit_error"):
        return f"RFA fit error max {rom.max_fit_error:.2e} ({rom.n_lags} lag(s), {rom.ss.n_states} states)"
    return f"validation NRMSE max {max(float(x) for x in rom.validation_nrmse):.2e} ({rom.ss.n_states} states)"
