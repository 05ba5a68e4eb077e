"""``romams wing``: import a wing planform from a Nastran deck, and print the wing-definition JSON Schema."""

from __future__ import annotations

import json
from pathlib import Path

import typer

from romams.cli.app import app
from romams_core.errors import InputError

wing_app = typer.Typer(no_args_is_help=True, help="Wing definitions: import from Nastran, JSON Schema.")
app.add_typer(wing_app, name="wing")


def bad_input(exc: ValueError, hints: dict[str, str], default: str) -> typer.BadParameter:
    """A usage error naming the CLI option of a core input error's field."""
    field = getattr(exc, "field", "") or str(exc).split(":", 1)[0]
    return typer.BadParameter(str(exc), param_hint=hints.get(field.split(".")[0], default))


@wing_app.command("import")
def import_command(
    deck: Path = typer.Argument(..., help="Nastran deck (.bdf/.dat/...) with CAERO1 panels and AERO/AEROS"),
    out: Path | None = typer.Option(None, "--out", help="write the wing definition JSON here (default: stdout)"),
    name: str | None = typer.Option(None, "--name", help="wing name (default: the file's stem)"),
    units: str = typer.Option("si", "--units", help="the deck's units: si, mm-t-s, in-lbf-s, ft-lbf-s"),
    symmetry: str | None = typer.Option(None, "--symmetry", help="override the AERO/AEROS symmetry: "
                                         "symmetric, antisymmetric or none (a free wing; the dlm, the uvlm "
                                         "and the tsd model all three)"),
    n_chord: int | None = typer.Option(None, "--n-chord", min=1, max=200, help="standard-mesh chordwise panels "
                                                                               "(default: the deck's boxes)"),
    n_span: int | None = typer.Option(None, "--n-span", min=1, max=200, help="standard-mesh spanwise panels"),
) -> None:
    """Read CAERO1 panels (NSPAN/NCHORD or AEFACT divisions) and AERO/AEROS (REFC, SYMXZ) into a planform-only
    wing definition (its modes then come from the deck's OP2: romams flutter --wing W.json --modes X.op2 --bdf X)."""
    from romams.wing_files import load_wing_file

    if not deck.is_file():
        raise typer.BadParameter(f"file {deck.name!r} not found", param_hint="DECK")
    try:
        wing = load_wing_file(deck, name=name, units=units, symmetry=symmetry, n_chord=n_chord, n_span=n_span)
    except ImportError as exc:
        raise typer.BadParameter(str(exc), param_hint="DECK") from None
    except InputError as exc:
        raise bad_input(exc, {"symmetry": "--symmetry", "units": "--units", "planform": "--n-chord/--n-span"},
                        "DECK") from None
    text = json.dumps(wing.to_dict(), indent=2)
    if out is None:
        typer.echo(text)
        return
    out.write_text(text + "\n")
    pf = wing.planform
    typer.echo(f"{wing.name}: root chord {pf.root_chord:.6g} m, tip chord {pf.tip_chord:.6g} m, semispan "
               f"{pf.semispan:.6g} m, {len(pf.kinks)} kink(s), {pf.n_chord} x {pf.n_span} panels, symmetry "
               f"{wing.symmetry} -> {out}",
               err=True)


@wing_app.command("schema")
def schema_command(out: Path | None = typer.Option(None, "--out", help="write the schema here (default: stdout)")
                   ) -> None:
    """JSON Schema of a wing definition (what --wing FILE.json and POST /api/v1/wings accept)."""
    from romams.wing_files import wing_schema

    text = json.dumps(wing_schema(), indent=2)
    if out is None:
        typer.echo(text)
    else:
        out.write_text(text + "\n")
