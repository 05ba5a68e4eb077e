"""Flutter plots (matplotlib, PNG or SVG): V-g / V-f (``vg``) and the safe envelope (``envelope``).

Uses matplotlib's object API (``Figure``) only, so it is safe in servers and workers (no pyplot state,
no GUI backend). This module keeps the names the CLI, the API and the benchmarks import.
"""

from __future__ import annotations

import io
from collections.abc import Mapping, Sequence
from typing import Any

from matplotlib.figure import Figure

from romams.plots.envelope import envelope_figure
from romams.plots.vg import AXES, G_LABEL, speed_axis, vg_figure

FORMATS = ("png", "svg")

__all__ = ["AXES", "FORMATS", "G_LABEL", "envelope_figure", "envelope_plot", "figure_bytes", "speed_axis",
           "vg_figure", "vg_plot"]


def _check_format(fmt: str) -> str:
    """Validated output format name."""
    f = str(fmt).lower()
    if f not in FORMATS:
        raise ValueError(f"fmt: must be one of {FORMATS}, got {fmt!r}")
    return f


def figure_bytes(fig: Figure, fmt: str = "png", dpi: int = 110) -> bytes:
    """Render a figure to PNG or SVG bytes (SVG without its date stamp, so equal figures give equal bytes)."""
    buf = io.BytesIO()
    f = _check_format(fmt)
    meta = {"Date": None} if f == "svg" else {"Software": None}
    fig.savefig(buf, format=f, dpi=dpi, bbox_inches="tight", metadata=meta)
    return buf.getvalue()


def vg_plot(result: Any, fmt: str = "png", title: str | None = None, axis: str = "tas") -> bytes:
    """V-g / V-f plot of a flutter result as PNG or SVG bytes (speed axis: tas, eas or q)."""
    return figure_bytes(vg_figure(result, title, axis), fmt)


def envelope_plot(envelopes: Mapping[str, Any] | Sequence[Any], benchmark: Any | None = None,
                  fmt: str = "png") -> bytes:
    """Envelope plot (designs vs benchmark) as PNG or SVG bytes."""
    return figure_bytes(envelope_figure(envelopes, benchmark), fmt)
