"""Planform panels of shape plots: axes in metres (span y to the right, chord x down, leading edge at the top),
root and tip labelled, a flow-direction arrow and one shared colour bar for shapes normalized to max |w| = 1."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.cm import ScalarMappable
from matplotlib.colors import Normalize
from matplotlib.figure import Figure

CMAP = "RdBu_r"
SHAPE_LABEL = "w / max|w|  (red up, blue down)"


def decorate(ax: Axes, y: np.ndarray, x: np.ndarray, labels: bool = True) -> None:
    """Axes of one planform panel (nodes y, x in m): equal aspect, LE at the top, root/tip and the flow arrow."""
    y_lo, y_hi = float(np.min(y)), float(np.max(y))
    x_lo, x_hi = float(np.min(x)), float(np.max(x))
    ax.set_aspect("equal")
    ax.set_xlim(y_lo - 0.04 * (y_hi - y_lo), y_hi + 0.04 * (y_hi - y_lo))
    ax.set_ylim(x_hi + 0.12 * (x_hi - x_lo), x_lo - 0.04 * (x_hi - x_lo))  # inverted: leading edge at the top
    ax.tick_params(labelsize=6)
    if labels:
        ax.set_xlabel("y (m), span", fontsize=7)
        ax.set_ylabel("x (m), chord", fontsize=7)
    below = x_hi + 0.08 * (x_hi - x_lo)
    ax.text(y_lo, below, "root", fontsize=7, ha="left", va="center", gid="root")
    ax.text(y_hi, below, "tip", fontsize=7, ha="right", va="center", gid="tip")
    ax.annotate("flow", xy=(y_hi, x_lo + 0.45 * (x_hi - x_lo)), xytext=(y_hi, x_lo + 0.05 * (x_hi - x_lo)),
                fontsize=7, ha="center", va="bottom", gid="flow",
                arrowprops=dict(arrowstyle="->", color="k", lw=1.0))


def colorbar(fig: Figure, axes: Sequence[Axes], label: str = SHAPE_LABEL) -> None:
    """One colour bar for all panels (shapes normalized to [-1, 1])."""
    sm = ScalarMappable(norm=Normalize(-1.0, 1.0), cmap=CMAP)
    fig.colorbar(sm, ax=list(axes), shrink=0.8, label=label)


def normalized(w: np.ndarray) -> np.ndarray:
    """A shape scaled to max |w| = 1 (a zero shape unchanged)."""
    w = np.asarray(w, dtype=float)
    lim = float(np.max(np.abs(w))) if w.size else 0.0
    return w / lim if lim > 0 else w
