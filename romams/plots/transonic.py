"""Figures of a transonic (TSD) mean flow: upper and lower surface Cp at a few span stations, sonic Cp marked."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from matplotlib.figure import Figure

#: span fractions shown by default
DEFAULT_STATIONS = (0.1, 0.4, 0.7, 0.9)


def plot_mean_flow_cp(mean_flow: Mapping[str, Any], stations: Sequence[float] = DEFAULT_STATIONS,
                      title: str | None = None) -> Figure:
    """Linear Cp on the upper (solid) and lower (dashed) surface vs x/c at the wing node columns nearest to
    ``stations`` (span fractions); the sonic Cp* is a horizontal line; Cp axis inverted (suction up)."""
    x = np.asarray(mean_flow["x_over_c"], dtype=float)
    eta = np.asarray(mean_flow["eta"], dtype=float)
    up = np.asarray(mean_flow["cp_upper"], dtype=float)
    lo = np.asarray(mean_flow["cp_lower"], dtype=float)
    fig = Figure(figsize=(7.0, 4.2), layout="constrained")
    ax = fig.subplots()
    picked = sorted({int(np.argmin(np.abs(eta - s))) for s in stations})
    for n, j in enumerate(picked):
        color = f"C{n}"
        ax.plot(x, up[:, j], "-", color=color, lw=1.2, label=f"y/b = {eta[j]:.2f} upper")
        ax.plot(x, lo[:, j], "--", color=color, lw=1.0, label=f"y/b = {eta[j]:.2f} lower")
    cps = float(mean_flow["cp_star"])
    ax.axhline(cps, color="k", lw=0.8, ls=":")
    ax.annotate(f"Cp* = {cps:.3f} (sonic)", (0.01, cps), textcoords="offset points", xytext=(2, -10), fontsize=8)
    ax.invert_yaxis()
    ax.set_xlim(0.0, 1.0)
    ax.set_xlabel("x/c (local chord)")
    ax.set_ylabel("Cp (linear, TSD)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2, loc="lower right")
    converged = "converged" if mean_flow.get("steady_converged") else "NOT converged"
    ax.set_title(title or f"TSD mean flow, M = {float(mean_flow['mach']):g} ({converged}, "
                 f"{mean_flow.get('steady_steps')} steps)", fontsize=10)
    return fig
