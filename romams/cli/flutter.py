"""``romams flutter``: flutter speed, frequency and dynamic pressure of one structure at one or more Machs.

It calls the same evaluation use case as the API's workers (``romams.services.evaluation``): same defaults,
same numbers, same JSON keys. What it adds is local: the basis is built and the ROMs are trained when missing.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from typing import Any

import typer

from romams.cli.app import WING_HELP, app
from romams.cli.modal import parse_design
from romams.services.errors import ServiceError
from romams.services.evaluation import DEFAULT_MAC_THRESHOLD, DEFAULT_N_MODES
from romams.services.flight import FlightCondition
from romams.services.training import DEFAULT_SOLVER, SOLVERS, available, is_external

#: the CLI option of each field of a Nastran read
NASTRAN_HINTS = {"subcase": "--subcase", "modes": "--op2-modes", "n_modes": "--op2-modes", "grids": "--grids",
                 "skip_below_hz": "--skip-below-hz", "units": "--units", "wtmass": "--wtmass", "bdf": "--bdf",
                 "op2": "--modes", "frequencies_hz": "--skip-below-hz", "spline": "--spline"}


def external_modes(modes_file: Path, bdf: Path | None, nastran: dict[str, Any] | None = None,
                   spline: str = "auto") -> Any:
    """ExternalModes read from a JSON, NPZ or Nastran OP2 (+ BDF) file; ``nastran``: NastranOptions fields."""
    from romams.cli.wing import bad_input
    from romams_core import modes_io

    suffix = modes_file.suffix.lower()
    try:
        if bdf is not None or suffix == ".op2":
            if bdf is None:
                raise typer.BadParameter("an OP2 file needs its BDF (--bdf FILE)", param_hint="--modes")
            from romams_core.nastran import NastranOptions

            modes = modes_io.load_modes_nastran(bdf, modes_file, options=NastranOptions(**(nastran or {})))
        elif suffix == ".npz":
            modes = modes_io.load_modes_npz(modes_file)
        else:
            modes = modes_io.load_modes_json(modes_file)
        return dataclasses.replace(modes, spline=spline)
    except ImportError as exc:
        raise typer.BadParameter(str(exc), param_hint="--bdf") from None
    except ValueError as exc:
        raise bad_input(exc, NASTRAN_HINTS, "--modes") from None


def flight_condition(density: float | None, altitude: float | None, matched: bool, sweep: str | None,
                     v_max: float | None, projection_correction: str | None = None) -> FlightCondition:
    """The flight condition from the CLI flags (default: the service's, constant speed at ISA 10 km)."""
    cond = _sweep_condition(density, altitude, matched, sweep, v_max)
    if projection_correction is None:
        return cond
    try:
        return dataclasses.replace(cond, projection_correction=projection_correction)  # validated on construction
    except ServiceError as exc:
        raise typer.BadParameter(exc.reason, param_hint="--projection-correction") from None


def _sweep_condition(density: float | None, altitude: float | None, matched: bool, sweep: str | None,
                     v_max: float | None) -> FlightCondition:
    """The sweep part of the flight condition from the CLI flags."""
    given = sum(x is not None for x in (density, altitude, sweep)) + bool(matched)
    if given > 1 and not (altitude is not None and sweep is not None and given == 2):
        raise typer.BadParameter("give at most one of --density, --altitude, --matched, --sweep "
                                 "(--altitude may accompany --sweep)")
    try:
        if matched:
            return FlightCondition.from_options(sweep="matched", v_max_m_s=v_max)
        if density is not None:
            return FlightCondition.from_options(sweep="constant-density", rho_ref=density, v_max_m_s=v_max)
        if altitude is not None and sweep is None:
            return FlightCondition.from_options(sweep="constant-density", altitude_ref_m=altitude, v_max_m_s=v_max)
        return FlightCondition.from_options(sweep=sweep, altitude_ref_m=altitude, v_max_m_s=v_max)
    except ServiceError as exc:
        raise typer.BadParameter(exc.reason, param_hint=f"--{(exc.field or 'sweep').replace('_', '-')}") from None


@app.command("flutter")
def flutter_command(
    wing: str = typer.Option("cropped-delta", "--wing", help=WING_HELP),
    baseline: bool = typer.Option(False, "--baseline", help="evaluate the wing's baseline structure"),
    design: list[str] | None = typer.Option(None, "--design", help="design variables NAME=VALUE,... (all of them; "
                                            "the option may be repeated)"),
    mach: list[float] = typer.Option([0.87], "--mach", help="Mach number (repeat for several; 0 = incompressible)"),
    density: float | None = typer.Option(None, "--density", help="constant-density sweep at RHO (kg/m^3)"),
    altitude: float | None = typer.Option(None, "--altitude", help="reference ISA altitude H (m); alone: "
                                                                   "constant-density sweep there"),
    matched: bool = typer.Option(False, "--matched", help="matched-point sweep: altitude with V = M a(h)"),
    sweep: str | None = typer.Option(None, "--sweep", help="constant-speed (default) | constant-density | matched"),
    v_max: float | None = typer.Option(None, "--v-max", help="top speed (m/s) of a constant-density sweep"),
    projection_correction: str | None = typer.Option(None, "--projection-correction", help="auto (default: dlm on "
                                                     "TSD ROMs) | none | dlm: the modes' part outside the basis "
                                                     "span by the DLM (ROM-AMS)"),
    basis_id: int | None = typer.Option(None, "--basis-id", help="basis to use (default: the wing's active one)"),
    method: str = typer.Option("rom-ams", "--method", help="rom-ams (basis ROM) or rom-pms (train on own modes)"),
    modes_file: Path | None = typer.Option(None, "--modes", help="external modes: JSON, NPZ, or Nastran OP2"),
    bdf: Path | None = typer.Option(None, "--bdf", help="Nastran BDF of the OP2 given with --modes"),
    subcase: int | None = typer.Option(None, "--subcase", help="OP2 eigenvector subcase (when it has several)"),
    op2_modes: str | None = typer.Option(None, "--op2-modes", help="OP2 modes: a count N (the first N) or mode "
                                         "ids 1,2,4 / 3-8"),
    skip_below_hz: float | None = typer.Option(None, "--skip-below-hz", help="leave out OP2 modes below this "
                                               "frequency (rigid-body modes), Hz"),
    grids: str | None = typer.Option(None, "--grids", help="OP2 GRIDs to use: ids 101-140,150, or 'planform' "
                                     "(inside the deck's CAERO1 panels)"),
    units: str = typer.Option("si", "--units", help="the deck's units: si, mm-t-s, in-lbf-s, ft-lbf-s"),
    wtmass: float | None = typer.Option(None, "--wtmass", help="override PARAM,WTMASS (structural mass only)"),
    spline: str = typer.Option("auto", "--spline", help="FE nodes -> standard mesh: auto (beam spline for a "
                               "stick model with rotations, else clough-tocher), surface, clough-tocher, linear, "
                               "beam"),
    n_modes: int = typer.Option(DEFAULT_N_MODES, "--n-modes", min=1, max=30,
                                help="modes per structure if the basis must be built"),
    samples: int = typer.Option(25, "--samples", min=1, help="LHS samples if the basis must be built"),
    mac: float = typer.Option(DEFAULT_MAC_THRESHOLD, "--mac", help="basis MAC threshold if the basis must be built"),
    solver: str = typer.Option(DEFAULT_SOLVER, "--solver", help="aerodynamic solver of the ROMs: dlm (doublet "
                               "lattice, default), uvlm, or tsd when installed (trained when missing)"),
    na: int | None = typer.Option(None, "--na", min=1, max=40, help="ARX orders (time-domain solvers; default 8)"),
    nb: int | None = typer.Option(None, "--nb", min=1, max=40),
    plot: Path | None = typer.Option(None, "--plot", help="write V-g / V-omega plots (PNG and SVG) here"),
    plot_axis: str = typer.Option("tas", "--plot-axis", help="speed axis of the V-g plots: tas (true airspeed), "
                                  "eas (equivalent airspeed) or q (dynamic pressure)"),
    as_json: bool = typer.Option(False, "--json", help="print one JSON object"),
) -> None:
    """Flutter analysis of one structure with the wing's ROM-AMS models (building / training what is missing)."""
    from romams.cli.text import console, progress_bar
    from romams.persistence import open_store
    from romams.pipeline import cli_models, resolve_wing, rom_identity, train_shapes
    from romams.services.evaluation import evaluate_structure_summary, pms_summary, structure_modal

    if method not in ("rom-ams", "rom-pms"):
        raise typer.BadParameter("must be rom-ams or rom-pms", param_hint="--method")
    for m in mach:
        if not (math.isfinite(m) and 0.0 <= m < 1.0):
            raise typer.BadParameter(f"{m!r}: must be in [0, 1) for the built-in subsonic solvers", param_hint="--mach")
    if not 0.0 < mac < 1.0:
        raise typer.BadParameter("must be in (0, 1)", param_hint="--mac")
    if plot_axis not in ("tas", "eas", "q"):
        raise typer.BadParameter(f"{plot_axis!r}: must be tas, eas or q", param_hint="--plot-axis")
    condition = flight_condition(density, altitude, matched, sweep, v_max, projection_correction)
    err = console(stderr=True)
    if design is not None and baseline:
        raise typer.BadParameter("give either --baseline or --design, not both", param_hint="--design")
    if design is None and modes_file is None and not baseline:
        baseline = True  # checked by the use case: a wing without a baseline needs --design
    store = open_store()
    try:
        wing_id, w = resolve_wing(store, wing)
    except ValueError as exc:
        raise typer.BadParameter(str(exc), param_hint="--wing") from None
    values = parse_design(design) if design is not None else None
    nastran = {"subcase": subcase, "modes": op2_modes, "skip_below_hz": skip_below_hz, "grids": grids,
               "units": units, "wtmass": wtmass}
    modes = external_modes(modes_file, bdf, nastran, spline) if modes_file is not None else None
    external = None
    if modes is not None and w.structure is None:  # a planform-only wing: its basis is these modes
        from romams_core.mesh import standard_mesh
        from romams_core.modes_io import wing_modal_result

        try:
            external = wing_modal_result(modes, w, standard_mesh(w.planform)).shapes
        except ValueError as exc:
            from romams.cli.wing import bad_input

            raise bad_input(exc, NASTRAN_HINTS, "--modes") from None
    machs = sorted(set(float(m) for m in mach))
    if not (is_external(solver) or (solver in SOLVERS and available(solver))):
        raise typer.BadParameter(f"unknown or unavailable solver {solver!r}; one of "
                                 f"{', '.join(x for x in SOLVERS if available(x))} or external:LABEL (an imported "
                                 "GAF table)", param_hint="--solver")
    try:
        ident = rom_identity(solver, na, nb, wing=w)
    except ServiceError as exc:
        raise typer.BadParameter(exc.reason, param_hint="--solver") from None
    try:
        models = cli_models(store, wing_id, w, machs, ident, basis_id=basis_id, samples=samples, modes=n_modes,
                            mac_threshold=mac, external=external, bar=lambda what: progress_bar(err, what))
        if method == "rom-pms":
            modal = structure_modal(models, values, modes)
            with progress_bar(err, f"ROM-PMS: training {len(machs)} ROM(s) on the structure's own modes") as bar:
                trained = train_shapes(models.mesh, modal.shapes, machs, ident, progress=bar)
            own = {m: (models.roms[m][0], r) for m, r in zip(machs, trained, strict=True)}  # ids: the settings' ROMs
            summary, result = pms_summary(models, modal, own, condition, external=modes is not None)
        else:
            summary, result = evaluate_structure_summary(models, design=values, modes=modes, condition=condition)
    except ServiceError as exc:
        hint = {"design": "--design", "modes": "--modes", "basis_id": "--basis-id"}.get(
            (exc.field or "").split(".")[0].split("[")[0], "--design/--modes")
        raise typer.BadParameter(exc.detail, param_hint=hint) from None
    except ValueError as exc:  # a core input error (e.g. a planform-only wing without --modes)
        from romams.cli.wing import bad_input

        raise bad_input(exc, {**NASTRAN_HINTS, "design": "--design", "modes": "--modes", "solver": "--solver",
                              "mach": "--mach"}, "--wing") from None
    if plot is not None:
        summary["plots"] = write_flutter_plots(plot, result.flutter, plot_axis)
    if as_json:
        typer.echo(json.dumps(summary))
        return
    echo_summary(summary)


def echo_summary(out: dict[str, Any]) -> None:
    """An evaluation summary as text on stdout: the structure, then one table row per Mach (4 significant
    figures, units in the headers); a Mach without flutter in the sweep range gets its message below."""
    from romams.cli.text import console, sig, table

    con = console(stderr=False)
    freqs = ", ".join(sig(f) for f in out["frequencies_hz"])
    con.print(f"{out['wing']}: mass {sig(out['mass_kg'])} kg, frequencies {freqs} Hz, MAC "
              + ", ".join(sig(x, 6) for x in out["mac"]) + f" (basis {out['basis_id']}, {out['n_basis']} shapes)")
    if out.get("warning"):
        con.print("WARNING: " + out["warning"])
    rows = [[f"{r['mach']:.2f}", r["sweep"], r["rho_ref_kg_m3"], r["v_true_m_s"], r["v_eas_m_s"],
             r["q_flutter_pa"], None if r["omega_flutter_rad_s"] is None else r["omega_flutter_rad_s"] / (2 * math.pi),
             r["flutter_mode"], ("yes" if r["sdoff"] else "no") if r["flutter_found"] else "-",
             r.get("safe_altitude_m")] for r in out["results"]]
    con.print(table(None, ["Mach", "sweep", "rho_ref (kg/m^3)", "V_true (m/s)", "V_EAS (m/s)", "q_f (Pa)",
                           "f_f (Hz)", "mode", "SDOFF", "safe altitude (m)"], rows))
    for r in out["results"]:
        if not r["flutter_found"]:
            con.print(f"M = {r['mach']:.2f}: {r['message']}")


def write_flutter_plots(directory: Path, results: list[Any], axis: str = "tas") -> list[str]:
    """V-g / V-omega figures (PNG and SVG) of each Mach's result on speed axis ``axis`` (tas, eas, q); the paths."""
    from romams.plots import flutter as fplots

    directory.mkdir(parents=True, exist_ok=True)
    paths = []
    for r in results:
        for ext in ("png", "svg"):
            p = directory / f"vg_M{r.mach:.2f}.{ext}"
            p.write_bytes(fplots.vg_plot(r, fmt=ext, axis=axis))
            paths.append(str(p))
    return paths
