"""``romams modal``: modal analysis of a wing design (frequencies, mass, optional mode-shape plots)."""

from __future__ import annotations

import json
from typing import Any

import typer

from romams.cli.app import WING_HELP, app
from romams_core.mesh import standard_mesh
from romams_core.structure.modal import modal_analysis
from romams_core.wing import WingDefinition, template


def resolve_wing(name: str) -> WingDefinition:
    """A wing file (.json / Nastran deck), else a template by name, else a stored wing by name or id."""
    from romams.wing_files import is_wing_file, load_wing_file

    if is_wing_file(name):
        try:
            return load_wing_file(name)
        except (ValueError, ImportError) as exc:
            raise typer.BadParameter(str(exc), param_hint="--wing") from None
    try:
        return template(name)
    except ValueError as tmpl_error:
        try:
            from romams.persistence import open_store

            found = open_store().wings.find(name)
        except Exception:  # noqa: BLE001 - a missing or unreachable store just means "not stored"
            found = None
        if found is None:
            raise typer.BadParameter(str(tmpl_error), param_hint="--wing") from None
        return found[1]


def parse_design(text: str | list[str]) -> dict[str, float]:
    """Parse ``NAME=VALUE,NAME=VALUE`` (or several such options) into a mapping (values as floats)."""
    out: dict[str, float] = {}
    joined = text if isinstance(text, str) else ",".join(text)
    for item in filter(None, (p.strip() for p in joined.split(","))):
        name, sep, value = item.partition("=")
        if not sep or not name.strip():
            raise typer.BadParameter(f"expected NAME=VALUE, got {item!r}", param_hint="--design")
        if name.strip() in out:
            raise typer.BadParameter(f"{name.strip()}: given twice", param_hint="--design")
        try:
            out[name.strip()] = float(value)
        except ValueError:
            raise typer.BadParameter(f"{name.strip()}: not a number: {value!r}", param_hint="--design") from None
    return out


def modal_summary(wing: WingDefinition, design: dict[str, float] | None, n_modes: int) -> tuple[dict[str, Any], Any]:
    """Run the modal analysis and return (JSON-able summary, ModalResult)."""
    r = modal_analysis(wing, design, n_modes=n_modes)
    summary = {
        "wing": wing.name,
        "design": None if design is None else {k: float(v) for k, v in zip(
            wing.variable_names, wing.design_vector(design), strict=True)},
        "frequencies_hz": [float(f) for f in r.frequencies_hz],
        "omega_rad_s": [float(w) for w in r.omega],
        "mass_kg": float(r.mass_kg),
        "n_fe_nodes": int(r.n_fe_nodes),
        "n_standard_nodes": int(r.shapes.shape[0]),
    }
    return summary, r


@app.command()
def modal(
    wing: str = typer.Option("cropped-delta", "--wing", help=WING_HELP),
    baseline: bool = typer.Option(False, "--baseline", help="Analyse the wing's baseline structure."),
    design: list[str] | None = typer.Option(None, "--design", help="Design values NAME=VALUE,... (all variables; "
                                            "the option may be repeated)."),
    modes: int = typer.Option(4, "--modes", min=1, max=50, help="Number of modes."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON only."),
    plot: str = typer.Option("", "--plot", help="Directory for mode-shape PNGs."),
) -> None:
    """Modal analysis of a wing: frequencies (Hz), structural mass (kg), FE size; optional mode plots."""
    w = resolve_wing(wing)
    if baseline and design:
        raise typer.BadParameter("give either --baseline or --design, not both", param_hint="--design")
    values = parse_design(design) if design else None
    if w.structure is None:
        raise typer.BadParameter(f"wing {w.name!r} is planform-only (no built-in structure): its modes come from "
                                 "outside (romams flutter --modes FILE)", param_hint="--wing")
    if values is None and not w.has_baseline:
        raise typer.BadParameter(f"wing {w.name!r} has no baseline; give --design "
                                 f"{','.join(n + '=...' for n in w.variable_names)}", param_hint="--design")
    try:
        summary, result = modal_summary(w, values, modes)
    except ValueError as exc:
        raise typer.BadParameter(str(exc), param_hint="--design") from None
    if plot:
        from romams.plots.modes import save_mode_plots

        files = save_mode_plots(result, standard_mesh(w.planform), plot, title=w.name)
        summary["plots"] = [str(p) for p in files]
    if as_json:
        typer.echo(json.dumps(summary))
        return
    from romams.cli.text import console, sig, table

    con = console(stderr=False)
    con.print(f"wing {w.name}: {'baseline' if values is None else 'design ' + json.dumps(summary['design'])}; "
              f"structural mass {sig(summary['mass_kg'])} kg, {summary['n_fe_nodes']} FE nodes")
    pairs = zip(summary["frequencies_hz"], summary["omega_rad_s"], strict=True)
    con.print(table(None, ["mode", "f (Hz)", "omega (rad/s)"], [[i, float(f), float(om)]
                                                                for i, (f, om) in enumerate(pairs, 1)]))
    if plot:
        con.print(f"plots: {', '.join(summary['plots'])}")
