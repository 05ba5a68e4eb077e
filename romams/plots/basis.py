"""Figures of a PCA mode basis: basis shapes on the planform, MAC vs basis size, original vs fitted modes."""

from __future__ import annotations

import inspect
import math
from collections.abc import Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from romams.plots.planform import CMAP, colorbar, decorate, normalized
from romams.services.evaluation import DEFAULT_MAC_THRESHOLD, FIT_ERROR_PER_RESIDUAL
from romams_core.basis import project
from romams_core.mesh import StandardMesh

ERROR_TICKS_PCT = (0.001, 0.003, 0.01, 0.03, 0.1, 0.3, 1.0, 3.0, 10.0, 30.0)
MAC_FLOOR = 1e-16  # 1 - MAC below round-off: shown at this value
#: Reference criteria drawn on the MAC plot: the paper's / the core's default basis criterion (about 4.5 %
#: flutter-speed error) and the service's default (validated to 1 %; romams.services.evaluation).
REFERENCE_THRESHOLDS = ((float(inspect.signature(project).parameters["mac_threshold"].default), "paper / core default"),
                        (DEFAULT_MAC_THRESHOLD, "service default"))


def _shape_axes(n: int, rows: int | None = None) -> tuple[Figure, np.ndarray]:
    """A figure with n planform panels (axes array flattened)."""
    cols = min(n, 4) if rows is None else math.ceil(n / rows)
    rows = math.ceil(n / cols) if rows is None else rows
    fig = Figure(figsize=(2.6 * cols, 2.6 * rows), layout="constrained")  # no pyplot: safe in servers/threads
    axes = fig.subplots(rows, cols, squeeze=False)
    for ax in axes.ravel()[n:]:
        ax.set_visible(False)
    return fig, axes.ravel()


def _draw_shape(ax: Axes, mesh: StandardMesh, w: np.ndarray, title: str) -> None:
    """Filled contour of one shape w [N] on the planform (x aft, y span; metres), normalized to max |w| = 1."""
    ax.pcolormesh(mesh.grid(mesh.y), mesh.grid(mesh.x), mesh.grid(normalized(w)), shading="gouraud", cmap=CMAP,
                  vmin=-1.0, vmax=1.0)
    decorate(ax, mesh.y, mesh.x)
    ax.set_title(title, fontsize=9)


def plot_basis_shapes(mesh: StandardMesh, shapes: np.ndarray, singular_values: Sequence[float] = ()) -> Figure:
    """Basis shapes [N, m] on the planform (paper Fig. 9)."""
    shapes = np.asarray(shapes, dtype=float)
    m = shapes.shape[1]
    fig, axes = _shape_axes(m)
    sv = list(singular_values)
    for i in range(m):
        extra = f"  s={sv[i]:.3g}" if i < len(sv) else ""
        _draw_shape(axes[i], mesh, shapes[:, i], f"basis {i + 1}{extra}")
    colorbar(fig, axes[:m])
    fig.suptitle("PCA basis shapes on the planform", fontsize=10)
    return fig


def log_residual(mac: np.ndarray) -> np.ndarray:
    """log10(1 - MAC) of fit MACs (1 - MAC floored at 1e-16, the round-off of a perfect fit)."""
    return np.log10(np.maximum(1.0 - np.asarray(mac, dtype=float), MAC_FLOOR))


def _thresholds(mac_threshold: float) -> dict[float, str]:
    """The MAC threshold lines: the basis's own and the reference criteria (value -> label)."""
    out = {float(t): f"{name}: MAC {t:g}" for t, name in REFERENCE_THRESHOLDS}
    out[float(mac_threshold)] = f"this basis: MAC {mac_threshold:g}"
    return out


def plot_mac_vs_basis_size(
    mac_by_m: np.ndarray,
    mac_threshold: float,
    n_basis: int,
    title: str = "fit MAC vs number of basis shapes",
    labels: Sequence[str] | None = None,
) -> Figure:
    """log10(1 - MAC) [M, k] of k modes (or curves) against the number of basis shapes 1..M (paper Fig. 11),
    with the threshold lines and, on the right axis, the estimated flutter-speed error 30 % x sqrt(1 - MAC)."""
    mac_by_m = np.asarray(mac_by_m, dtype=float)
    if mac_by_m.ndim == 1:
        mac_by_m = mac_by_m[:, None]
    n_m, k = mac_by_m.shape
    labels = list(labels) if labels is not None else [f"mode {j + 1}" for j in range(k)]
    fig = Figure(figsize=(6.2, 4.0), layout="constrained")
    ax = fig.subplots()
    m = np.arange(1, n_m + 1)
    y = log_residual(mac_by_m)
    for j in range(k):
        ax.plot(m, y[:, j], marker="o", ms=3, label=labels[j])
    for t, lab in _thresholds(mac_threshold).items():
        own = t == float(mac_threshold)
        ax.axhline(float(log_residual(np.array(t))), color="k" if own else "0.5", ls="--" if own else ":",
                   lw=0.9, label=lab)
    ax.axvline(n_basis, color="grey", ls="-.", lw=0.8, label=f"m = {n_basis}")
    ax.set_xlabel("number of basis shapes m")
    ax.set_ylabel("log10(1 - MAC)   (lower is better)")
    ax.set_xticks(m)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    err = ax.secondary_yaxis("right", functions=(_error_pct, _error_inverse))
    err.set_yticks(ERROR_TICKS_PCT, [f"{t:g}" for t in ERROR_TICKS_PCT])
    err.set_ylabel("estimated flutter-speed error (%)", fontsize=8)
    ax.set_title(title, fontsize=10)
    return fig


def _error_pct(y: np.ndarray) -> np.ndarray:
    """Estimated ROM-AMS flutter-speed error (%) at log10(1 - MAC) = y: 100 x 0.30 x sqrt(1 - MAC)."""
    return 100.0 * FIT_ERROR_PER_RESIDUAL * np.power(10.0, 0.5 * np.asarray(y, dtype=float))


def _error_inverse(e: np.ndarray) -> np.ndarray:
    """Inverse of ``_error_pct``."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return 2.0 * np.log10(np.maximum(np.asarray(e, dtype=float), 1e-300) / (100.0 * FIT_ERROR_PER_RESIDUAL))


def plot_fit_comparison(mesh: StandardMesh, shapes: np.ndarray, fitted: np.ndarray, macs: Sequence[float]) -> Figure:
    """Original (top row) vs basis-fitted (bottom row) mode shapes [N, k] with their MACs (paper Fig. 10)."""
    shapes, fitted = np.asarray(shapes, dtype=float), np.asarray(fitted, dtype=float)
    k = shapes.shape[1]
    fig, axes = _shape_axes(2 * k, rows=2)
    for j in range(k):
        _draw_shape(axes[j], mesh, shapes[:, j], f"mode {j + 1}: original")
        _draw_shape(axes[k + j], mesh, fitted[:, j], f"fitted, MAC {macs[j]:.4f}")
    colorbar(fig, axes[:2 * k])
    return fig


def save(fig: Figure, path: str) -> None:
    """Write a figure (format from the suffix: .png, .svg)."""
    fig.savefig(path, dpi=120)
