"""``romams keys``: make API keys and the hashed entries the service settings store instead of them."""

from __future__ import annotations

import sys

import typer

from romams.cli.app import app
from romams.keys import SCOPES, ApiKey, digest, new_key

keys_app = typer.Typer(no_args_is_help=True, help="API keys: random new ones, and the sha256 entries of "
                                                   "ROMAMS_API_KEYS (the service keeps only hashes).")
app.add_typer(keys_app, name="keys")


def _scope(scope: str) -> str:
    """A checked scope name."""
    if scope not in SCOPES:
        raise typer.BadParameter(f"one of {', '.join(SCOPES)}", param_hint="--scope")
    return scope


@keys_app.command("hash")
def hash_cmd(
    key: str = typer.Argument(None, help="the key (default: read from standard input, which keeps it out of the "
                                         "shell history and the process list)"),
    scope: str = typer.Option("write", help="read (dashboard and GETs) or write (also the mutating endpoints)"),
) -> None:
    """Print the ROMAMS_API_KEYS entry (sha256:<hex>:<scope>) of a key."""
    text = (key if key is not None else sys.stdin.readline()).strip()
    if not text:
        raise typer.BadParameter("an empty key", param_hint="KEY")
    typer.echo(ApiKey(digest(text), _scope(scope)).entry())


@keys_app.command("new")
def new_cmd(scope: str = typer.Option("write", help="read or write")) -> None:
    """Make a random key: prints the key (give it to the client) and, on the second line, its entry for
    ROMAMS_API_KEYS (give that to the service)."""
    key = new_key()
    typer.echo(key)
    typer.echo(ApiKey(digest(key), _scope(scope)).entry())
