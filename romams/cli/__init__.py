"""``romams`` command line: each subcommand lives in its own module and registers on ``app``."""

from __future__ import annotations

import importlib

from romams.cli.app import app

_COMMAND_MODULES = ("modal", "basis", "train", "flutter", "pk", "demo", "service", "wing", "keys")

for _name in _COMMAND_MODULES:
    try:
        importlib.import_module(f"romams.cli.{_name}")
    except ModuleNotFoundError as exc:  # a command module not written yet
        if exc.name != f"romams.cli.{_name}":
            raise


def main() -> None:
    """Console-script entry point."""
    app()


__all__ = ["app", "main"]
