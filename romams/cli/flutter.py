"""``romams flutter``: flutter speed, frequency and dynamic pressure of one structure at one or more Machs."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import typer

from romams.cli.app import app
from romams.cli.modal import parse_design
from romams.pipeline import (
    SweepChoice,
    ensure_basis,
    ensure_roms,
    flutter_pms,
    resolve_wing,
    result_row,
    rom_identity,
)


def structure_modes(wing: Any, mesh: Any, baseline: bool, design: str | None, modes_file: Path | None,
                    bdf: Path | None, n_modes: int) -> Any:
    """ModalResult of the structure named on the command line (design, baseline or external modes)."""
    from romams_core.structure.modal import modal_analysis

    if modes_file is not None:
        from romams_core import modes_io

        suffix = modes_file.suffix.lower()
        if bdf is not None or suffix == ".op2":
            if bdf is None:
                raise typer.BadParameter("an OP2 file needs its BDF (--bdf FILE)", param_hint="--modes")
            modes = modes_io.load_modes_nastran(bdf, modes_file)
        elif suffix == ".npz":
            modes = modes_io.load_modes_npz(modes_file)
        else:
            modes = modes_io.load_modes_json(modes_file)
        return modes_io.external_modal_result(modes, mesh)
    if design is not None and baseline:
        raise typer.BadParameter("give either --baseline or --design, not both", param_hint="--design")
    values = parse_design(design) if design is not None else None
    if values is None and wing.design_variables and not wing.has_baseline:
        raise typer.BadParameter(f"wing {wing.name!r} has no baseline: give --design", param_hint="--design")
    return modal_analysis(wing, values, n_modes=n_modes, mesh=mesh)


def sweep_choice(density: float | None, altitude: float | None, matched: bool, sweep: str | None) -> SweepChoice:
    """The flutter sweep from the mutually exclusive CLI flags (default: constant density at ISA 10 km)."""
    given = sum(x is not None and x is not False for x in (density, altitude, sweep)) + bool(matched)
    if given > 1:
        raise typer.BadParameter("give at most one of --density, --altitude, --matched, --sweep")
    if matched:
        return SweepChoice("matched")
    if density is not None:
        if not (math.isfinite(density) and density > 0):
            raise typer.BadParameter("must be a finite density > 0 (kg/m^3)", param_hint="--density")
        return SweepChoice("constant-density", rho_ref=density)
    if altitude is not None:
        return SweepChoice("constant-density", altitude_ref_m=altitude)
    return SweepChoice(sweep or "constant-density")


@app.command("flutter")
def flutter_command(
    wing: str = typer.Option("cropped-delta", "--wing", help="wing template name, or a stored wing's name / id"),
    baseline: bool = typer.Option(False, "--baseline", help="evaluate the wing's baseline structure"),
    design: str | None = typer.Option(None, "--design", help="design variables NAME=VALUE,... (all of them)"),
    mach: list[float] = typer.Option([0.87], "--mach", help="Mach number (repeat for several)"),
    density: float | None = typer.Option(None, "--density", help="constant-density sweep at RHO (kg/m^3)"),
    altitude: float | None = typer.Option(None, "--altitude", help="constant-density sweep at ISA altitude H (m)"),
    matched: bool = typer.Option(False, "--matched", help="matched-point sweep: altitude with V = M a(h)"),
    sweep: str | None = typer.Option(None, "--sweep", help="constant-density | constant-speed | matched"),
    method: str = typer.Option("rom-ams", "--method", help="rom-ams (basis ROM) or rom-pms (train on own modes)"),
    modes_file: Path | None = typer.Option(None, "--modes", help="external modes: JSON, NPZ, or Nastran OP2"),
    bdf: Path | None = typer.Option(None, "--bdf", help="Nastran BDF of the OP2 given with --modes"),
    n_modes: int = typer.Option(4, "--n-modes", min=1, max=30, help="structural modes in the analysis"),
    samples: int = typer.Option(25, "--samples", min=1, help="LHS samples if the basis must be built"),
    mac: float = typer.Option(0.98, "--mac", help="basis MAC threshold if the basis must be built"),
    na: int = typer.Option(8, "--na", min=1, max=40),
    nb: int = typer.Option(8, "--nb", min=1, max=40),
    plot: Path | None = typer.Option(None, "--plot", help="write V-g / V-omega plots (PNG and SVG) here"),
    as_json: bool = typer.Option(False, "--json", help="print one JSON object"),
) -> None:
    """Flutter analysis of one structure with the wing's ROM-AMS models (training what is missing)."""
    from romams.persistence import open_store
    from romams_core.basis import project
    from romams_core.evaluate import evaluate_structure
    from romams_core.mesh import standard_mesh

    if method not in ("rom-ams", "rom-pms"):
        raise typer.BadParameter("must be rom-ams or rom-pms", param_hint="--method")
    for m in mach:
        if not (math.isfinite(m) and 0.0 <= m < 1.0):
            raise typer.BadParameter(f"{m!r}: must be in [0, 1) for the built-in subsonic solver", param_hint="--mach")
    choice = sweep_choice(density, altitude, matched, sweep)
    store = open_store()
    try:
        wing_id, w = resolve_wing(store, wing)
    except ValueError as exc:
        raise typer.BadParameter(str(exc), param_hint="--wing") from None
    mesh = standard_mesh(w.planform)
    try:
        modal = structure_modes(w, mesh, baseline, design, modes_file, bdf, n_modes)
    except ValueError as exc:
        raise typer.BadParameter(str(exc), param_hint="--design/--modes") from None
    basis_id, basis = ensure_basis(store, wing_id, w, samples=samples, modes=n_modes, mac_threshold=mac)
    ident = rom_identity("uvlm", na, nb)
    machs = sorted(set(float(m) for m in mach))
    proj = project(basis.shapes, modal.shapes, mac)
    if method == "rom-pms":
        results = flutter_pms(modal, mesh, machs, ident, choice)
    else:
        roms = ensure_roms(store, wing_id, w, basis_id, basis, machs, ident=ident)
        ev = evaluate_structure(modal, basis.shapes, {m: r for m, (_, r) in roms.items()}, sweep=choice.sweep,
                                mac_threshold=mac, flutter_options=choice.flutter_options())
        results = ev.flutter
    mass = float(getattr(modal, "mass_kg", math.nan))
    out: dict[str, Any] = {
        "wing": w.name,
        "method": method,
        "mass_kg": mass if math.isfinite(mass) else None,
        "frequencies_hz": [float(f) for f in modal.frequencies_hz],
        "mac": [float(x) for x in proj.mac],
        "mac_ok": bool(proj.ok),
        "results": [result_row(r) for r in results],
    }
    if not proj.ok:
        out["warning"] = (f"modes {[i + 1 for i, p in enumerate(proj.poor_fit) if p]} fit the basis with "
                          f"MAC < {mac:g}: ROM-AMS results for this structure are not reliable")
    if plot is not None:
        out["plots"] = write_flutter_plots(plot, results)
    if as_json:
        typer.echo(json.dumps(out))
        return
    freqs = ", ".join(f"{f:.2f}" for f in out["frequencies_hz"])
    typer.echo(f"{w.name}: mass {out['mass_kg']} kg, frequencies {freqs} Hz, MAC "
               + ", ".join(f"{x:.4f}" for x in out["mac"]))
    if "warning" in out:
        typer.echo("WARNING: " + out["warning"])
    for r in out["results"]:
        if r["flutter_found"]:
            typer.echo(f"  M = {r['mach']:.2f} ({r['sweep']}): V_f = {r['v_flutter_m_s']:.2f} m/s, "
                       f"omega_f = {r['omega_flutter_rad_s']:.1f} rad/s, q_f = {r['q_flutter_pa']:.0f} Pa, "
                       f"mode {r['flutter_mode']}{', SDOFF' if r['sdoff'] else ''}")
        else:
            typer.echo(f"  M = {r['mach']:.2f} ({r['sweep']}): {r['message']}")


def write_flutter_plots(directory: Path, results: list[Any]) -> list[str]:
    """V-g / V-omega figures (PNG and SVG) of each Mach's result; returns the paths."""
    from romams.plots import flutter as fplots

    directory.mkdir(parents=True, exist_ok=True)
    paths = []
    for r in results:
        for ext in ("png", "svg"):
            p = directory / f"vg_M{r.mach:.2f}.{ext}"
            p.write_bytes(fplots.vg_plot(r, fmt=ext))
            paths.append(str(p))
    return paths


