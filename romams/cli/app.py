"""The typer application that every ``romams`` subcommand module registers on."""

import typer

app = typer.Typer(add_completion=False, no_args_is_help=True, help="ROM-AMS flutter service and tools.")


@app.callback()
def _root() -> None:
    """ROM-AMS flutter service and tools (a callback keeps subcommands even when only one is registered)."""

#: help text of every ``--wing`` option
WING_HELP = "a template name, a stored wing's name / id, or a wing file (.json definition, Nastran .bdf deck)"
