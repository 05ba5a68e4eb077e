"""Figures the API serves for stored evaluations: V-g / V-omega per Mach and the safe-altitude envelope."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from matplotlib.figure import Figure


def vg_figure(results: Sequence[Any]) -> Figure:
    """Damping g and frequency (rad/s) of every structural branch vs speed (m/s), one column per Mach."""
    n = max(len(results), 1)
    fig = Figure(figsize=(3.2 * n, 5.2), layout="constrained")
    axes = np.atleast_2d(fig.subplots(2, n, sharex="col", squeeze=False))
    for j, r in enumerate(results):
        v = np.asarray(r.v, dtype=float)
        g = np.atleast_2d(np.asarray(r.g, dtype=float))
        w = np.atleast_2d(np.asarray(r.omega, dtype=float))
        ax_g, ax_w = axes[0, j], axes[1, j]
        for b in range(g.shape[1] if g.size else 0):
            ax_g.plot(v, g[:, b], lw=1.2, label=f"mode {b + 1}")
            ax_w.plot(v, w[:, b], lw=1.2)
        ax_g.axhline(0.0, color="k", lw=0.6)
        if r.v_flutter_m_s is not None:
            for ax in (ax_g, ax_w):
                ax.axvline(r.v_flutter_m_s, color="r", ls="--", lw=0.8)
        vf = f", V_f = {r.v_flutter_m_s:.1f} m/s" if r.v_flutter_m_s else ", no flutter"
        ax_g.set_title(f"M = {r.mach:.3f}{vf}", fontsize=9)
        ax_g.set_ylabel("damping g")
        ax_w.set_ylabel("frequency (rad/s)")
        ax_w.set_xlabel("V (m/s, equivalent at the reference density)" if r.sweep == "constant-speed" else "V (m/s)")
        ax_g.grid(alpha=0.3)
        ax_w.grid(alpha=0.3)
        if j == 0 and g.size:
            ax_g.legend(fontsize=7)
    return fig


def envelope_figure(design: Any, baseline: dict[str, Any] | None) -> Figure:
    """Lowest safe altitude (m) vs Mach of a design, with the baseline's when one is stored."""
    fig = Figure(figsize=(5.0, 3.6), layout="constrained")
    ax = fig.subplots()
    env = design.envelope
    ax.plot(env.mach, env.safe_altitude_m, "o-", label="design")
    if baseline:
        pts = [(r["mach"], r["safe_altitude_m"]) for r in baseline.get("results", []) if r.get("safe_altitude_m")
               is not None]
        if pts:
            m, h = zip(*pts, strict=True)
            ax.plot(m, h, "s--", label="baseline")
    ax.set_xlabel("Mach")
    ax.set_ylabel("lowest safe altitude (m)")
    ax.set_title(f"flutter envelope ({env.margin:.2f} speed margin)", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return fig
