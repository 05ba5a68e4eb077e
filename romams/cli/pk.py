"""``romams pk``: p-k flutter of one structure from a GAF table computed on its own modes (e.g. Nastran's QHH of a
SOL 145 run, or a CFD code's), without a basis or a ROM: the classical analysis, for checks against the ROMs."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import typer

from romams.cli.app import app
from romams.cli.flutter import NASTRAN_HINTS, WING_HELP, external_modes, flight_condition


@app.command("pk")
def pk_command(
    wing: str = typer.Option("cropped-delta", "--wing", help=WING_HELP + " (its reference chord and damping)"),
    modes_file: Path = typer.Option(..., "--modes", help="the structure's modes: JSON, NPZ, or Nastran OP2 "
                                                         "(frequencies and generalized masses are used)"),
    bdf: Path | None = typer.Option(None, "--bdf", help="Nastran BDF of the OP2 given with --modes"),
    op2_modes: str | None = typer.Option(None, "--op2-modes", help="OP2 modes: a count N or mode numbers"),
    subcase: int | None = typer.Option(None, "--subcase", help="OP2 eigenvector subcase"),
    units: str = typer.Option("si", "--units", help="the deck's units: si, mm-t-s, in-lbf-s, ft-lbf-s"),
    gaf: Path = typer.Option(..., "--gaf", help="GAF table on those modes, in their order: NPZ, CSV, or Nastran's "
                                                "QHH from an OUTPUT4 / punch file"),
    mach: float | None = typer.Option(None, "--mach", help="Mach number (needed for CSV and QHH tables)"),
    k_values: str | None = typer.Option(None, "--k-values", help="with a QHH table: its MKAERO1 k values"),
    matrix: str | None = typer.Option(None, "--matrix", help="with a QHH table: the matrix name (default QHH)"),
    mach_index: int | None = typer.Option(None, "--mach-index", min=0, help="with a QHH table: the Mach block"),
    skip_modes: int | None = typer.Option(None, "--skip-modes", min=0, help="with a QHH table: leading modes "
                                                                           "(rows and columns) to drop"),
    refc: float | None = typer.Option(None, "--refc", help="with a QHH table: the AERO card's REFC (m)"),
    density: float | None = typer.Option(None, "--density", help="constant-density sweep at RHO (kg/m^3)"),
    altitude: float | None = typer.Option(None, "--altitude", help="reference ISA altitude H (m)"),
    matched: bool = typer.Option(False, "--matched", help="matched-point sweep: altitude with V = M a(h)"),
    sweep: str | None = typer.Option(None, "--sweep", help="constant-speed (default) | constant-density | matched"),
    v_max: float | None = typer.Option(None, "--v-max", help="top speed (m/s) of a constant-density sweep"),
    as_json: bool = typer.Option(False, "--json", help="print one JSON object"),
) -> None:
    """p-k flutter of one structure from its own GAF table (no basis, no ROM)."""
    from romams.cli.train import read_table
    from romams.persistence import open_store
    from romams.pipeline import resolve_wing
    from romams_core.gaf_table import on_mass_normalized_modes
    from romams_core.mesh import standard_mesh
    from romams_core.pk import AeroTable, pk_flutter

    try:
        _, w = resolve_wing(open_store(), wing)
    except ValueError as exc:
        raise typer.BadParameter(str(exc), param_hint="--wing") from None
    modes = external_modes(modes_file, bdf, {"subcase": subcase, "modes": op2_modes, "units": units})
    qhh = {"k_values": k_values, "matrix": matrix, "mach_index": mach_index, "skip_modes": skip_modes, "refc": refc}
    table = read_table(gaf, mach, qhh, w)
    if table.n_shapes != modes.frequencies_hz.size:
        raise typer.BadParameter(f"the table has {table.n_shapes} modes, --modes {modes.frequencies_hz.size}: the "
                                 "table must be computed on those modes, in their order", param_hint="--gaf")
    table = on_mass_normalized_modes(table, modes.generalized_masses)
    condition = flight_condition(density, altitude, matched, sweep, v_max)
    aero = AeroTable(k=table.k_values, h=table.gaf, mach=table.mach, description=f"GAF table {gaf.name}")
    c_ref = standard_mesh(w.planform).c_ref
    try:
        res = pk_flutter(2 * math.pi * modes.frequencies_hz, aero, c_ref, table.mach, sweep=condition.sweep,
                         zeta=w.modal_damping, **condition.flutter_options())
    except ValueError as exc:
        from romams.cli.wing import bad_input

        raise bad_input(exc, {**NASTRAN_HINTS, "k": "--gaf", "mach": "--mach", "sweep": "--sweep"}, "--gaf") from None
    out = pk_summary(res, modes.frequencies_hz)
    if as_json:
        typer.echo(json.dumps(out))
        return
    if out["flutter_found"]:
        typer.echo(f"M {out['mach']:g}: flutter at V {out['v_flutter_m_s']:.4g} m/s (EAS {out['v_eas_m_s']:.4g} "
                   f"m/s), q {out['q_flutter_pa']:.5g} Pa, {out['f_flutter_hz']:.4g} Hz, mode "
                   f"{out['flutter_mode']}, k {out['k_flutter']:.4g}")
    else:
        typer.echo(f"M {out['mach']:g}: no flutter in the range ({out['message']})")


def pk_summary(res: Any, frequencies_hz: np.ndarray) -> dict[str, Any]:
    """JSON-able summary of a p-k result (SI units: m/s, Pa, Hz, kg/m^3)."""
    keys = ("mach", "sweep", "flutter_found", "v_flutter_m_s", "v_eas_m_s", "q_flutter_pa", "rho_flutter",
            "k_flutter", "flutter_mode", "message", "c_ref")
    out = {k: getattr(res, k) for k in keys}
    om = res.omega_flutter_rad_s
    out["f_flutter_hz"] = None if om is None else float(om) / (2 * math.pi)
    out["method"] = "p-k on the structure's own GAF table"
    out["frequencies_hz"] = [float(f) for f in frequencies_hz]
    return {k: (float(v) if isinstance(v, np.floating) else v) for k, v in out.items()}
