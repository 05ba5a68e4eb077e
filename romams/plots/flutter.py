"""V-g / V-omega plots of a flutter result and safe-envelope plots (matplotlib, PNG or SVG).

Uses matplotlib's object API (``Figure``) only, so it is safe in servers and workers (no pyplot state,
no GUI backend).
"""

from __future__ import annotations

import io
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from matplotlib.figure import Figure

FORMATS = ("png", "svg")
G_LABEL = "damping g = 2 Re(s)/|s|  (g > 0: unstable)"


def _check_format(fmt: str) -> str:
    """Validated output format name."""
    f = str(fmt).lower()
    if f not in FORMATS:
        raise ValueError(f"fmt: must be one of {FORMATS}, got {fmt!r}")
    return f


def figure_bytes(fig: Figure, fmt: str = "png", dpi: int = 110) -> bytes:
    """Render a figure to PNG or SVG bytes."""
    buf = io.BytesIO()
    fig.savefig(buf, format=_check_format(fmt), dpi=dpi, bbox_inches="tight")
    return buf.getvalue()


def _speed_label(result: Any) -> str:
    """x-axis label for a result's sweep."""
    if result.sweep == "constant-speed":
        return f"equivalent speed sqrt(2q/rho_ref) (m/s), rho_ref = {result.rho_ref:.4g} kg/m^3"
    if result.sweep == "matched":
        return "true speed V = M a(h) (m/s), altitude decreasing ->"
    return f"speed V (m/s) at rho = {result.rho_ref:.4g} kg/m^3"


def _flutter_on_axis(result: Any) -> float:
    """The flutter point on the plot's speed axis (m/s): the axis is sqrt(2 q / rho_ref) on a constant-speed
    sweep (the true speed is constant there), the true speed otherwise."""
    if result.sweep == "constant-speed":
        return math.sqrt(2.0 * float(result.q_flutter_pa) / float(result.rho_ref))
    return float(result.v_true_m_s if result.v_true_m_s is not None else result.v_flutter_m_s)


def vg_figure(result: Any, title: str | None = None) -> Figure:
    """V-g and V-f figure (two panels) of a FlutterResult-like object, flutter point marked."""
    v = np.asarray(result.v, dtype=float)
    g = np.asarray(result.g, dtype=float)
    om = np.asarray(result.omega, dtype=float)
    if v.ndim != 1 or g.shape != om.shape or g.shape[0] != v.size:
        raise ValueError("result: v [nv], g [nv, k] and omega [nv, k] arrays are required")
    fig = Figure(figsize=(7.0, 6.4))
    ax_g, ax_f = fig.subplots(2, 1, sharex=True)
    for j in range(g.shape[1]):
        (line,) = ax_g.plot(v, g[:, j], marker=".", label=f"mode {j + 1}")
        ax_f.plot(v, om[:, j] / (2 * math.pi), marker=".", color=line.get_color())
    ax_g.axhline(0.0, color="k", lw=0.8)
    if result.flutter_found and result.q_flutter_pa is not None:
        vf = _flutter_on_axis(result)
        ff = float(result.omega_flutter_rad_s) / (2 * math.pi)
        ax_g.plot([vf], [0.0], "r*", ms=12, label=f"flutter (mode {result.flutter_mode})")
        ax_f.plot([vf], [ff], "r*", ms=12)
        for ax in (ax_g, ax_f):
            ax.axvline(vf, color="r", lw=0.6, ls="--")
    ax_g.set_ylabel(G_LABEL)
    ax_f.set_ylabel("frequency Im(s)/2pi (Hz)")
    ax_f.set_xlabel(_speed_label(result))
    ax_g.legend(loc="best", fontsize=8)
    for ax in (ax_g, ax_f):
        ax.grid(True, alpha=0.3)
    head = title or f"M = {result.mach:g}, {result.sweep} sweep, {result.coupling} coupling"
    if result.flutter_found and result.q_flutter_pa is not None:
        head += f"\nq_f = {result.q_flutter_pa:.5g} Pa, omega_f = {result.omega_flutter_rad_s:.4g} rad/s"
        if getattr(result, "v_eas_m_s", None) is not None:
            head += f", V_true = {result.v_true_m_s:.4g} m/s, V_EAS = {result.v_eas_m_s:.4g} m/s"
        if result.sdoff:
            head += "  [SDOFF]"
    else:
        head += "\nno flutter in the sweep range"
    ax_g.set_title(head, fontsize=10)
    return fig


def envelope_figure(
    envelopes: Mapping[str, Any] | Sequence[Any],
    benchmark: Any | None = None,
    title: str = "Safe flight envelope (lowest safe altitude)",
) -> Figure:
    """Safe altitude vs Mach for designs (name -> Envelope, or a list) and an optional benchmark envelope."""
    items = list(envelopes.items()) if isinstance(envelopes, Mapping) else [
        (f"design {i + 1}", e) for i, e in enumerate(envelopes)]
    if not items and benchmark is None:
        raise ValueError("envelopes: nothing to plot")
    fig = Figure(figsize=(7.0, 4.8))
    ax = fig.subplots()
    if benchmark is not None:
        m = np.asarray(benchmark.mach, float)
        h = np.asarray(benchmark.safe_altitude_m, float) / 1000.0
        top = float(benchmark.altitude_range_m[1]) / 1000.0
        ax.plot(m, h, "k-o", lw=2, label="benchmark")
        ax.fill_between(m, h, top, color="tab:green", alpha=0.12, label="safe (benchmark)")
        ax.fill_between(m, float(benchmark.altitude_range_m[0]) / 1000.0, h, color="tab:red", alpha=0.10,
                        label="flutter risk (benchmark)")
    for name, env in items:
        ax.plot(np.asarray(env.mach, float), np.asarray(env.safe_altitude_m, float) / 1000.0, "--s", label=name)
    ax.set_xlabel("Mach number")
    ax.set_ylabel("lowest safe altitude (km), q <= q_f / margin^2")
    ax.set_title(title, fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    return fig


def vg_plot(result: Any, fmt: str = "png", title: str | None = None) -> bytes:
    """V-g / V-f plot of a flutter result as PNG or SVG bytes."""
    return figure_bytes(vg_figure(result, title), fmt)


def envelope_plot(envelopes: Mapping[str, Any] | Sequence[Any], benchmark: Any | None = None,
                  fmt: str = "png") -> bytes:
    """Envelope plot (designs vs benchmark) as PNG or SVG bytes."""
    return figure_bytes(envelope_figure(envelopes, benchmark), fmt)
