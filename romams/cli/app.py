"""The typer application that every ``romams`` subcommand module registers on."""

import typer

app = typer.Typer(add_completion=False, no_args_is_help=True, help="ROM-AMS flutter service and tools.")
