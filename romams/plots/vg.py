"""V-g / V-f figure of a flutter result by the conventions of Nastran / ZAERO flutter output.

From q = 0 (the wind-off frequencies in the legend), every tracked point and extra points near each crossing
(``FlutterResult.curves``), three panels: damping g on its full range, g zoomed around 0 (so that small humps
show) and the frequency in Hz; the speed axis is chosen among TAS, EAS and q (``AXES``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from romams_core.atmosphere import RHO_SEA_LEVEL
from romams_core.flutter.curves import VgCurves

AXES = ("tas", "eas", "q")
G_LABEL = "damping g = 2 Re(s)/|s|  (g > 0: unstable)"
G_ZOOM_WINDOW = 0.1  # the zoomed panel is scaled to the damping values within +-this of 0
G_ZOOM_MIN = 1e-3  # smallest half-height of the zoomed panel


def check_axis(axis: str) -> str:
    """Validated speed-axis name (ValueError naming ``axis``)."""
    a = str(axis).lower()
    if a not in AXES:
        raise ValueError(f"axis: must be one of {AXES}, got {axis!r}")
    return a


def vg_data(result: Any) -> VgCurves:
    """The V-g curves of a result: ``result.curves`` (from q = 0), else its coarse sweep points (older results)."""
    curves = getattr(result, "curves", None)
    if curves is not None and np.size(curves.q):
        return curves
    v, q, rho = (np.asarray(getattr(result, n), float) for n in ("v", "q", "rho"))
    g, om = np.asarray(result.g, float), np.asarray(result.omega, float)
    if v.ndim != 1 or g.shape != om.shape or g.ndim != 2 or g.shape[0] != v.size:
        raise ValueError("result: v [nv], g [nv, k] and omega [nv, k] arrays are required")
    v_true = np.full(v.size, float(result.v_true_m_s or result.a_ref * result.mach)) \
        if result.sweep == "constant-speed" else v
    return VgCurves(q=q, v=v, v_true=v_true, v_eas=np.sqrt(2.0 * q / RHO_SEA_LEVEL), rho=rho,
                    altitude=np.asarray(getattr(result, "altitude", np.full(v.size, np.nan)), float), g=g,
                    omega=om, kind=np.ones(v.size, np.int8))


def axis_rho(result: Any, curves: VgCurves) -> np.ndarray:
    """Density (kg/m^3) of the TAS axis at each point: the flight density, rho_ref on a constant-speed sweep (its
    axis is the true speed at rho_ref with the same q, sqrt(2 q / rho_ref))."""
    if result.sweep == "constant-speed":
        return np.full(curves.q.shape, float(result.rho_ref))
    return np.asarray(curves.rho, float)


def speed_axis(result: Any, axis: str = "tas") -> tuple[np.ndarray, np.ndarray, str]:
    """(x [n] in m/s or Pa, mask of the points drawn [n], label) of the V-g plot's speed axis.

    tas: true airspeed (on a constant-speed sweep, sqrt(2 q / rho_ref); on a matched sweep the density ramp at
    the top altitude -- q from 0 to q(h_top) at one speed -- is left out); eas: sqrt(2 q / rho_0); q: Pa.
    """
    c = vg_data(result)
    a = check_axis(axis)
    keep = np.ones(c.q.shape, bool)
    if a == "eas":
        return np.asarray(c.v_eas, float), keep, f"equivalent airspeed EAS = sqrt(2q/rho_0) (m/s), rho_0 = " \
                                                 f"{RHO_SEA_LEVEL:.4g} kg/m^3"
    if a == "q":
        return np.asarray(c.q, float), keep, "dynamic pressure q (kPa)"
    if result.sweep == "matched":
        keep = np.isfinite(np.asarray(c.altitude, float))
        return np.asarray(c.v, float), keep, "true airspeed V = M a(h) (m/s), altitude decreasing ->"
    if result.sweep == "constant-speed":
        return np.asarray(c.v, float), keep, (f"TAS at rho_ref = {result.rho_ref:.4g} kg/m^3: sqrt(2q/rho_ref) "
                                              "(m/s)")
    return np.asarray(c.v, float), keep, f"true airspeed V (m/s) at rho = {result.rho_ref:.4g} kg/m^3"


def flutter_x(result: Any, axis: str) -> float | None:
    """The flutter point on the speed axis (m/s, or Pa for q); None without a flutter point."""
    if not result.flutter_found or result.q_flutter_pa is None:
        return None
    a = check_axis(axis)
    if a == "q":
        return float(result.q_flutter_pa)
    if a == "eas":
        return math.sqrt(2.0 * float(result.q_flutter_pa) / RHO_SEA_LEVEL)
    if result.sweep == "constant-speed":
        return math.sqrt(2.0 * float(result.q_flutter_pa) / float(result.rho_ref))
    return float(result.v_true_m_s if result.v_true_m_s is not None else result.v_flutter_m_s)


def zoom_limits(g: np.ndarray) -> tuple[float, float]:
    """y-limits of the zoomed damping panel: the range of the g values within +-G_ZOOM_WINDOW of 0, padded."""
    vals = np.asarray(g, float)
    near = vals[np.isfinite(vals) & (np.abs(vals) <= G_ZOOM_WINDOW)]
    lo = min(float(near.min()) if near.size else 0.0, 0.0)
    hi = max(float(near.max()) if near.size else 0.0, 0.0)
    pad = 0.1 * (hi - lo)
    lo, hi = lo - pad, hi + pad
    half = 0.5 * G_ZOOM_MIN
    return (min(lo, -half), max(hi, half))


def _title(result: Any, title: str | None) -> str:
    """Figure title: case and flutter point (frequencies in Hz, as on the frequency axis)."""
    head = title or f"M = {result.mach:g}, {result.sweep} sweep, {result.coupling} coupling"
    if not (result.flutter_found and result.q_flutter_pa is not None):
        return head + "\nno flutter in the sweep range"
    head += (f"\nq_f = {result.q_flutter_pa:.5g} Pa, f_f = {result.omega_flutter_rad_s / (2 * math.pi):.4g} Hz"
             f" (mode {result.flutter_mode})")
    if getattr(result, "v_eas_m_s", None) is not None:
        head += f", V_true = {result.v_true_m_s:.4g} m/s, V_EAS = {result.v_eas_m_s:.4g} m/s"
    return head + ("  [SDOFF]" if result.sdoff else "")


def _mark_flutter(result: Any, axes: list[Axes], scale: float, axis: str) -> None:
    """Flutter point (star) and a dashed vertical line on every panel."""
    xf = flutter_x(result, axis)
    if xf is None:
        return
    ff = float(result.omega_flutter_rad_s) / (2 * math.pi)
    axes[0].plot([xf * scale], [0.0], "r*", ms=12, label=f"flutter (mode {result.flutter_mode})")
    axes[1].plot([xf * scale], [0.0], "r*", ms=12)
    axes[2].plot([xf * scale], [ff], "r*", ms=12)
    for ax in axes:
        ax.axvline(xf * scale, color="r", lw=0.6, ls="--")


def vg_figure(result: Any, title: str | None = None, axis: str = "tas") -> Figure:
    """V-g (full and zoomed around g = 0) and V-f figure of a FlutterResult from q = 0, flutter point marked."""
    c = vg_data(result)
    x, keep, label = speed_axis(result, axis)
    scale = 1e-3 if check_axis(axis) == "q" else 1.0
    g, f = np.asarray(c.g, float)[keep], np.asarray(c.omega, float)[keep] / (2 * math.pi)
    x = x[keep] * scale
    wind_off = c.q[0] == 0.0
    fig = Figure(figsize=(7.0, 8.6), layout="constrained")
    axes = list(fig.subplots(3, 1, sharex=True, height_ratios=[1.0, 1.0, 1.2]))
    for j in range(g.shape[1]):
        f0 = f" (wind-off {np.asarray(c.omega)[0, j] / (2 * math.pi):.4g} Hz)" if wind_off else ""
        (line,) = axes[0].plot(x, g[:, j], marker=".", ms=3, label=f"mode {j + 1}{f0}")
        axes[1].plot(x, g[:, j], marker=".", ms=3, color=line.get_color())
        axes[2].plot(x, f[:, j], marker=".", ms=3, color=line.get_color())
    for ax in axes[:2]:
        ax.axhline(0.0, color="k", lw=0.8)
    _mark_flutter(result, axes, scale, axis)
    axes[1].set_ylim(*zoom_limits(g))
    axes[0].set_ylabel(G_LABEL, fontsize=8)
    axes[1].set_ylabel("g, zoomed around 0", fontsize=8)
    axes[2].set_ylabel("frequency Im(s)/2pi (Hz)", fontsize=8)
    axes[2].set_xlabel(label)
    axes[0].legend(loc="best", fontsize=7, title="q = 0: in-vacuo modes" if wind_off else None, title_fontsize=7)
    for ax in axes:
        ax.grid(True, alpha=0.3)
    axes[0].set_title(_title(result, title), fontsize=9)
    return fig
