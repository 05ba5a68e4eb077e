"""Text output of the CLI: fixed-width tables of numbers to 4 significant figures with their units, and a
progress bar on every wait (on stderr: stdout stays free for ``--json`` and for the results)."""

from __future__ import annotations

import math
import re
import sys
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any

#: fraction done (0-1), message: the core's progress callback
ProgressFn = Callable[[float, str], None]

#: width of a console that is not a terminal (a log file, a pipe): wide enough that no table wraps
PIPE_WIDTH = 160


def sig(x: float | None, digits: int = 4, signed: bool = False) -> str:
    """``x`` to ``digits`` significant figures: positional from 1e-4 to 1e7, else scientific; "-" when missing."""
    if x is None or not math.isfinite(float(x)):
        return "-"
    x = float(f"{float(x):.{digits - 1}e}")  # rounded first, so that 99.996 is 100.0, not 100.00
    plus = "+" if signed and x > 0 else ""
    if x == 0.0:
        return "0"
    e = math.floor(math.log10(abs(x)))
    if -4 <= e < 7:
        return f"{plus}{x:.{max(digits - 1 - e, 0)}f}"
    return f"{plus}{x:.{digits - 1}e}"


def console(stderr: bool = True) -> Any:
    """A rich Console on stderr (or stdout) that does not wrap lines or tables when it is not a terminal."""
    from rich.console import Console

    stream = sys.stderr if stderr else sys.stdout
    tty = stream.isatty()
    return Console(stderr=stderr, highlight=False, soft_wrap=not tty, width=None if tty else PIPE_WIDTH)


def table(title: str | None, columns: Sequence[str], rows: Sequence[Sequence[Any]]) -> Any:
    """A fixed-width table: ``columns`` are headers with their units, e.g. "V_EAS (m/s)"; numbers in ``rows``
    are printed to 4 significant figures (``sig``), text as is; numeric columns are right-aligned."""
    from rich import box
    from rich.table import Table

    t = Table(title=title, box=box.SIMPLE_HEAD, title_justify="left", pad_edge=False, show_edge=False)
    numeric = [all(_numeric(r[i]) for r in rows) for i in range(len(columns))]
    for name, num in zip(columns, numeric, strict=True):
        t.add_column(name, justify="right" if num else "left", no_wrap=True)
    for r in rows:
        t.add_row(*(cell(v) for v in r))
    return t


_NUMBER = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)(e[+-]?\d+)?|-")


def _numeric(v: Any) -> bool:
    """True for a number, a missing value or a formatted number (right-aligned in a table)."""
    return v is None or (isinstance(v, int | float) and not isinstance(v, bool)) or (
        isinstance(v, str) and _NUMBER.fullmatch(v) is not None)


def cell(v: Any) -> str:
    """One table cell: a number to 4 significant figures (an int as is), None as "-", anything else as text."""
    if isinstance(v, bool) or v is None:
        return "-" if v is None else ("yes" if v else "no")
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return sig(v)
    return str(v)


@contextmanager
def progress_bar(con: Any, description: str) -> Iterator[ProgressFn]:
    """A transient progress bar with the elapsed wall time on ``con`` while the block runs; yields the
    ``progress(fraction, message)`` callback to hand to the work (a non-terminal console shows nothing)."""
    from rich.progress import BarColumn, Progress, TaskProgressColumn, TextColumn, TimeElapsedColumn

    columns = (TextColumn("{task.description}"), BarColumn(), TaskProgressColumn(), TimeElapsedColumn(),
               TextColumn("[dim]{task.fields[note]}"))
    with Progress(*columns, console=con, transient=True) as bar:
        task = bar.add_task(description, total=1.0, note="")

        def update(fraction: float, message: str = "") -> None:
            bar.update(task, completed=min(max(float(fraction), 0.0), 1.0), note=message[:60])

        yield update
