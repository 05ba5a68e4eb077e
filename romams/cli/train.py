"""``romams train``: identify the aerodynamic ROM of a wing's basis shapes at one Mach number (local store)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import typer

from romams.cli.app import WING_HELP, app
from romams.pipeline import ensure_basis, ensure_roms, resolve_wing, rom_identity
from romams.services.errors import ServiceError
from romams.services.training import DEFAULT_SOLVER, SOLVERS, check_options, is_frequency_solver, quality_line


def _reduce_option(value: str | None) -> int | str | None:
    """--reduce: 'auto', a state count, or None."""
    if value is None or value == "none":
        return None
    if value == "auto":
        return "auto"
    try:
        order = int(value)
    except ValueError:
        raise typer.BadParameter("must be 'auto', 'none' or a positive integer", param_hint="--reduce") from None
    if order < 1:
        raise typer.BadParameter("must be a positive integer", param_hint="--reduce")
    return order


def _refine_option(value: str) -> float | None:
    """--supercritical-refine: 'none' or a factor (checked by the core with the rest of the settings)."""
    if value.strip().lower() == "none":
        return None
    try:
        return float(value)
    except ValueError:
        raise typer.BadParameter("must be 'none' or a factor in [1, 4]", param_hint="--supercritical-refine") from None


@app.command("train")
def train_command(
    wing: str = typer.Option("cropped-delta", "--wing", help=WING_HELP),
    mach: float | None = typer.Option(None, "--mach", min=0.0, max=0.99, help="free-stream Mach number (default "
                                      "0.87; with --gaf: the table's)"),
    solver: str = typer.Option(DEFAULT_SOLVER, "--solver", help="aerodynamic solver: dlm (doublet lattice, "
                               "rational-function ROM), uvlm (time domain, ARX ROM) or tsd (transonic small "
                               "disturbance, minutes per Mach)"),
    na: int | None = typer.Option(None, "--na", min=0, max=64, help="ARX output delay order (time-domain solvers; "
                                  "default 8)"),
    nb: int | None = typer.Option(None, "--nb", min=1, max=64, help="ARX input delay order (time-domain solvers; "
                                  "default as --na)"),
    reduce: str | None = typer.Option(None, "--reduce", help="balanced reduction of the ROM: 'auto' or a state "
                                      "count (ARX: truncation; dlm: singular perturbation of the RFA)"),
    n_steps: int | None = typer.Option(None, "--n-steps", min=16, help="ARX: signal length (steps)"),
    seed: int = typer.Option(0, "--seed", help="ARX: seed of the excitation signals"),
    n_lags: int | None = typer.Option(None, "--n-lags", min=0, max=12, help="dlm: RFA lag roots (default: automatic)"),
    lattice_refine: int | None = typer.Option(None, "--lattice-refine", min=1, max=4, help="dlm: DLM boxes per "
                                              "standard-mesh panel edge (default 2; 1 trains about 7x faster)"),
    grid_scale: float | None = typer.Option(None, "--grid-scale", help="tsd: cell counts of the default grid "
                                            "multiplied by this (0.25-4; 0.5 is a quick run)"),
    coefficients: str | None = typer.Option(None, "--coefficients", help="tsd: the coefficient set of the TSD "
                                            "equation, ames (default, CAP-TSD's) or nlr (sonic speed within 3 % of "
                                            "the isentropic one; docs/tsd_2d_validation.md 3.2a)"),
    linearity_check: bool = typer.Option(False, "--linearity-check", help="tsd: rerun at half amplitude and report "
                                         "the deviation from linear scaling"),
    anchor_k: str | None = typer.Option(None, "--anchor-k", help="tsd: the reduced frequencies at which the ROM is "
                                        "anchored to direct step runs of each shape (default 0.025,0.05,0.1; "
                                        "'none': a plain ROM, which warns of its low-k scatter; docs/transonic.md "
                                        "7.11)"),
    supercritical_refine: str | None = typer.Option(None, "--supercritical-refine", help="tsd: when the mean flow "
                                                    "on the requested grid is supercritical, train on it with every "
                                                    "cell count x this (default 1.5; 'none': keep the grid, which "
                                                    "warns; docs/transonic.md 7.21)"),
    gaf: Path | None = typer.Option(None, "--gaf", help="import a GAF table (NPZ, CSV, or Nastran's QHH from an "
                                    "OUTPUT4 .op4 or punch .pch file, computed on the basis shapes) as the ROM of "
                                    "solver external:LABEL instead of training one"),
    label: str | None = typer.Option(None, "--label", help="with --gaf: the table's name (solver external:LABEL)"),
    k_values: str | None = typer.Option(None, "--k-values", help="with a QHH --gaf: the MKAERO1 reduced "
                                        "frequencies (Nastran's k on REFC/2), e.g. 0.001,0.05,0.1"),
    matrix: str | None = typer.Option(None, "--matrix", help="with a QHH --gaf: the matrix name (default QHH)"),
    mach_index: int | None = typer.Option(None, "--mach-index", min=0, help="with a QHH --gaf: the Mach block "
                                          "(0 = the MKAERO1 card's first Mach; default 0)"),
    skip_modes: int | None = typer.Option(None, "--skip-modes", min=0, help="with a QHH --gaf: leading modes "
                                          "(rows and columns) that are not basis shapes (default 0)"),
    refc: float | None = typer.Option(None, "--refc", help="with a QHH --gaf: the AERO card's REFC (m); k is "
                                      "rescaled by c_ref / REFC (default: the wing's recorded REFC, else c_ref)"),
    export_gaf: Path | None = typer.Option(None, "--export-gaf", help="write the ROM's GAF table (NPZ) here"),
    export_package: Path | None = typer.Option(None, "--export-package", help="write the external-CFD training "
                                               "package (zip: excitation, shapes, settings.json, README) of the "
                                               "basis at --mach here, and train nothing"),
    gac: Path | None = typer.Option(None, "--gac", help="identify the ROM of solver external:LABEL from the GAC "
                                    "time histories (NPZ 'gac' or CSV) an external CFD run computed for a package"),
    settings_file: Path | None = typer.Option(None, "--settings", help="with --gac: the package's settings.json"),
    as_json: bool = typer.Option(False, "--json", help="print one JSON object"),
    plot: Path | None = typer.Option(None, "--plot", help="write PNG figures (signals, validation) here"),
) -> None:
    """Train (or find in the store) the ROM of the wing's basis at one Mach; builds the basis first if needed."""
    from romams.cli.text import console, progress_bar, sig
    from romams.persistence import open_store
    from romams_core.training import TrainingError

    if solver not in SOLVERS:
        raise typer.BadParameter(f"unknown solver {solver!r}; one of {', '.join(SOLVERS)}", param_hint="--solver")
    qhh = {"k_values": k_values, "matrix": matrix, "mach_index": mach_index, "skip_modes": skip_modes, "refc": refc}
    if gaf is None and any(v is not None for v in qhh.values()):
        raise typer.BadParameter("applies to a Nastran QHH table imported with --gaf", param_hint="--k-values/--matrix"
                                 "/--mach-index/--skip-modes/--refc")
    options: dict[str, Any] = {}
    red = _reduce_option(reduce)
    if red is not None:
        options["reduce_order"] = red
    if n_steps is not None:
        options["n_steps"] = n_steps
    if seed:
        options["seed"] = seed
    if is_frequency_solver(solver):
        arx_only = [k for k in options if k != "reduce_order"]
        if arx_only:
            raise typer.BadParameter(f"{', '.join(arx_only)}: ARX settings do not apply to {solver}",
                                     param_hint="--n-steps/--seed")
        if n_lags is not None:
            options["n_lags"] = n_lags
        if lattice_refine is not None:
            options["lattice_refine"] = lattice_refine
    elif n_lags is not None or lattice_refine is not None:
        raise typer.BadParameter(f"applies to a frequency-domain solver (dlm), not {solver}",
                                 param_hint="--n-lags/--lattice-refine")
    if solver == "tsd":
        if grid_scale is not None:
            options["grid_scale"] = grid_scale
        if linearity_check:
            options["linearity_check"] = True
        if coefficients is not None:
            options["coefficients"] = coefficients
        if anchor_k is not None and anchor_k.strip().lower() == "none":
            options["anchor_k"] = None
        elif anchor_k is not None:
            try:
                options["anchor_k"] = [float(v) for v in anchor_k.split(",")]
            except ValueError:
                raise typer.BadParameter(f"comma-separated reduced frequencies, got {anchor_k!r}",
                                         param_hint="--anchor-k") from None
        if supercritical_refine is not None:
            options["supercritical_refine"] = _refine_option(supercritical_refine)
    elif (grid_scale is not None or linearity_check or anchor_k is not None or coefficients is not None
          or supercritical_refine is not None):
        raise typer.BadParameter(f"applies to the transonic solver (tsd), not {solver}",
                                 param_hint="--grid-scale/--linearity-check/--anchor-k/--coefficients"
                                 "/--supercritical-refine")
    store = open_store()
    try:
        wing_id, w = resolve_wing(store, wing)
    except ValueError as exc:
        raise typer.BadParameter(str(exc), param_hint="--wing") from None
    try:
        basis_id, basis = ensure_basis(store, wing_id, w)  # says on stderr when it builds one
    except ValueError as exc:  # a planform-only wing: its basis comes from its modes (romams flutter --modes)
        raise typer.BadParameter(str(exc), param_hint="--wing") from None
    if export_package is not None:
        _export_package(w, basis_id, basis, 0.87 if mach is None else mach, na, nb, n_steps, seed, export_package)
        return
    if gac is not None or gaf is not None:  # an imported model
        if label is None:
            raise typer.BadParameter("an imported model needs a name: --label NAME (its solver is external:NAME)",
                                     param_hint="--label")
        if gac is not None:
            rom_id, rom = _import_gac(store, wing_id, w, basis_id, basis, gac, label, mach, settings_file)
        else:
            assert gaf is not None
            rom_id, rom = _import_gaf(store, wing_id, w, basis_id, basis, gaf, label, mach, options, qhh)
    else:
        mach = 0.87 if mach is None else mach
        try:
            ident = rom_identity(solver, na, nb, options, wing=w)
            check_options(solver, ident["options"], basis.n_basis)
        except ServiceError as exc:
            raise typer.BadParameter(exc.reason, param_hint=exc.field or "--solver") from None
        try:
            with progress_bar(console(), f"training the {solver} ROM at M {mach:g}") as bar:
                roms = ensure_roms(store, wing_id, w, basis_id, basis, [mach], ident=ident, processes=1,
                                   progress=bar)
        except TrainingError as exc:
            typer.echo(f"training failed: {exc}", err=True)
            raise typer.Exit(code=2) from None
        except ValueError as exc:
            raise typer.BadParameter(str(exc)) from None
        rom_id, rom = roms[float(mach)]
    report: dict[str, Any] = {
        "rom_id": rom_id,
        "mach": float(rom.mach),
        "n_basis": int(rom.n_basis),
        "validation_nrmse": [float(x) for x in rom.validation_nrmse],
        "train_seconds": round(float(rom.train_seconds), 3),
        "wing_id": wing_id,
        "basis_id": basis_id,
        "solver": rom.solver,
        "na": rom.na,
        "nb": rom.nb,
        "n_states": rom.ss.n_states,
        "dt_star": getattr(rom, "dt_star", 0.0),  # 0: a continuous (rational-function) ROM
        "warnings": list(rom.warnings),
    }
    if _is_rfa(rom):
        report.update(kind="rfa", n_lags=rom.n_lags, fit_error_max=rom.max_fit_error, fit_error=rom.fit_error.tolist(),
                      k_max=float(rom.k_values[-1]), solver_seconds=round(float(rom.solver_seconds), 3))
    if getattr(rom, "mean_flow", None):
        report.update(mean_flow_converged=rom.mean_flow.get("steady_converged"),
                      mean_flow_steps=rom.mean_flow.get("steady_steps"), linearity_error=rom.linearity_error,
                      solver_seconds=round(float(rom.solver_seconds), 3))
    if plot is not None:
        report["plots"] = _write_plots(plot, rom)
    if export_gaf is not None:
        if not _is_rfa(rom):
            raise typer.BadParameter(f"a {rom.solver} ARX ROM has no GAF table (a rational-function ROM has)",
                                     param_hint="--export-gaf")
        from romams_core.gaf_table import GafTable, gaf_npz

        export_gaf.parent.mkdir(parents=True, exist_ok=True)
        export_gaf.write_bytes(gaf_npz(GafTable(rom.mach, rom.k_values, rom.gaf)))
        report["gaf_table"] = str(export_gaf)
    if as_json:
        typer.echo(json.dumps(report))
        return
    for msg in rom.warnings:
        typer.echo(f"warning: {msg}", err=True)
    typer.echo(f"rom {rom_id}: M = {rom.mach:g}, {rom.solver}, {rom.n_basis} basis shapes, {quality_line(rom)}, "
               f"trained in {sig(rom.train_seconds)} s (wall)")


def _export_package(wing: Any, basis_id: int, basis: Any, mach: float, na: int | None, nb: int | None,
                    n_steps: int | None, seed: int, path: Path) -> None:
    """Write the external-CFD training package (``romams.services.external_cfd``) and say what it holds."""
    from romams.services.external_cfd import export_package

    given = {"na": na, "nb": nb, "n_steps": n_steps}  # None: the package's defaults
    opts: dict[str, Any] = {"seed": seed, **{k: v for k, v in given.items() if v is not None}}
    try:
        data, settings = export_package(wing, basis_id, basis, mach, opts)
    except ServiceError as exc:
        raise typer.BadParameter(exc.reason, param_hint=f"--{str(exc.field).split('.')[-1].replace('_', '-')}"
                                 ) from None
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data)
    typer.echo(f"wrote {path}: basis {basis_id} ({basis.n_basis} shapes) at M {mach:g}, {2 * settings['n_steps']} "
               f"samples of dt* {settings['dt_star']:g}; run it, then: romams train --gac FILE --label NAME "
               f"--mach {mach:g} --settings settings.json")


def _import_gac(store: Any, wing_id: int, wing: Any, basis_id: int, basis: Any, path: Path, label: str,
                mach: float | None, settings_file: Path | None) -> tuple[int, Any]:
    """(rom_id, ROM) identified from an external run's GAC (``romams.services.external_cfd``)."""
    from romams.services.external_cfd import import_gac, parse_gac

    if settings_file is None:
        raise typer.BadParameter("give the package's settings.json", param_hint="--settings")
    try:
        settings = json.loads(settings_file.read_text())
        data = path.read_bytes()
    except (OSError, ValueError) as exc:
        raise typer.BadParameter(f"cannot read: {exc}", param_hint="--gac/--settings") from None
    if isinstance(settings, dict) and mach is None:
        mach = settings.get("mach")
    if not isinstance(settings, dict) or mach is None:
        raise typer.BadParameter("settings.json must be the package's (with its mach)", param_hint="--settings")
    hints = {"label": "--label", "mach": "--mach", "gac": "--gac", "file": "--gac"}
    bid = int(settings.get("basis_id", basis_id))
    try:
        package_basis = basis if bid == basis_id else store.bases.load(bid)
    except KeyError:
        raise typer.BadParameter(f"basis {bid} of the package is not in this store", param_hint="--settings") from None
    try:
        return import_gac(store, wing_id, wing, bid, package_basis, float(mach), parse_gac(data, path.name), label,
                          {k: v for k, v in settings.items() if k != "basis_id"})
    except ServiceError as exc:
        raise typer.BadParameter(exc.reason, param_hint=hints.get(str(exc.field), f"--settings ({exc.field})")
                                 ) from None


def _is_rfa(rom: Any) -> bool:
    """True for a rational-function ROM (a GAF table fitted: the dlm's or an imported table's)."""
    from romams_core.training_rfa import TrainedRfaRom

    return isinstance(rom, TrainedRfaRom)


def _import_gaf(store: Any, wing_id: int, wing: Any, basis_id: int, basis: Any, path: Path, label: str,
                mach: float | None, options: dict[str, Any], qhh: dict[str, Any]) -> tuple[int, Any]:
    """(rom_id, ROM) of an imported GAF table (``romams.services.gaf_import``; ``qhh``: the settings of a Nastran
    QHH file, None where not given), usage errors naming the option."""
    from romams.services.gaf_import import import_table

    fit = {k: v for k, v in options.items() if k in ("n_lags", "reduce_order")}
    extra = sorted(set(options) - set(fit))
    if extra:
        raise typer.BadParameter(f"{', '.join(extra)}: not settings of an imported table", param_hint="--gaf")
    table = read_table(path, mach, qhh, wing)
    try:
        return import_table(store, wing_id, wing, basis_id, basis, table, label, **fit)
    except ServiceError as exc:
        raise typer.BadParameter(exc.reason, param_hint=_table_hint(exc.field)) from None


def _table_hint(field: str | None) -> str:
    """The option that sets a table field (its QHH settings are --k-values, --matrix, ...)."""
    from romams.services.gaf_import import QHH_FIELDS

    hints = {"label": "--label", "mach": "--mach", "n_lags": "--n-lags", "reduce_order": "--reduce",
             **{k: "--" + k.replace("_", "-") for k in QHH_FIELDS}}
    return hints.get(str(field), f"--gaf ({field})")


def read_table(path: Path, mach: float | None, qhh: dict[str, Any], wing: Any) -> Any:
    """The GafTable of a table file (NPZ, CSV, Nastran OP4 / punch QHH with the ``qhh`` settings, None where not
    given; ``wing`` for a QHH's reference chord), usage errors naming the option."""
    from romams.services.gaf_import import parse_k_list, parse_table

    try:
        if qhh.get("k_values") is not None:
            qhh = {**qhh, "k_values": parse_k_list(qhh["k_values"])}
        return parse_table(path.read_bytes(), path.name, mach, qhh, wing)
    except OSError as exc:
        raise typer.BadParameter(f"cannot read {path.name}: {exc.strerror}", param_hint="--gaf") from None
    except ImportError as exc:
        raise typer.BadParameter(str(exc), param_hint="--gaf") from None
    except ServiceError as exc:
        raise typer.BadParameter(exc.reason, param_hint=_table_hint(exc.field)) from None


def _write_plots(directory: Path, rom: Any) -> list[str]:
    """Excitation and validation PNGs; returns their paths."""
    from romams.plots.training import plot_signals, plot_validation, save

    directory.mkdir(parents=True, exist_ok=True)
    if _is_rfa(rom):
        from romams.plots.training import plot_rfa_fit

        path = directory / f"training_rfa_M{rom.mach:g}.png"
        save(plot_rfa_fit(rom), str(path))
        return [str(path)]
    paths = [directory / f"training_signals_M{rom.mach:g}.png", directory / f"training_validation_M{rom.mach:g}.png"]
    save(plot_signals(rom), str(paths[0]))
    save(plot_validation(rom), str(paths[1]))
    if getattr(rom, "mean_flow", None):
        from romams.plots.transonic import plot_mean_flow_cp

        paths.append(directory / f"mean_flow_cp_M{rom.mach:g}.png")
        save(plot_mean_flow_cp(rom.mean_flow), str(paths[-1]))
    return [str(p) for p in paths]
