"""Figures of a PCA mode basis: basis shapes on the planform, MAC vs basis size, original vs fitted modes."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from romams_core.mesh import StandardMesh


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
    """Filled contour of one shape w [N] on the planform (x aft, y span; metres)."""
    lim = float(np.max(np.abs(w))) or 1.0
    ax.pcolormesh(mesh.grid(mesh.y), mesh.grid(mesh.x), mesh.grid(w), shading="gouraud", cmap="RdBu_r",
                  vmin=-lim, vmax=lim)
    ax.set_aspect("equal")
    ax.invert_yaxis()  # leading edge at the top, span to the right
    ax.set_title(title, fontsize=9)
    ax.set_xticks([])
    ax.set_yticks([])


def plot_basis_shapes(mesh: StandardMesh, shapes: np.ndarray, singular_values: Sequence[float] = ()) -> Figure:
    """Basis shapes [N, m] on the planform (paper Fig. 9)."""
    shapes = np.asarray(shapes, dtype=float)
    m = shapes.shape[1]
    fig, axes = _shape_axes(m)
    sv = list(singular_values)
    for i in range(m):
        extra = f"  s={sv[i]:.3g}" if i < len(sv) else ""
        _draw_shape(axes[i], mesh, shapes[:, i], f"basis {i + 1}{extra}")
    fig.suptitle("PCA basis shapes (red up, blue down)", fontsize=10)
    return fig


def plot_mac_vs_basis_size(
    mac_by_m: np.ndarray,
    mac_threshold: float,
    n_basis: int,
    title: str = "fit MAC vs number of basis shapes",
    labels: Sequence[str] | None = None,
) -> Figure:
    """MAC [M, k] of k modes (or curves) against the number of basis shapes 1..M (paper Fig. 11)."""
    mac_by_m = np.asarray(mac_by_m, dtype=float)
    if mac_by_m.ndim == 1:
        mac_by_m = mac_by_m[:, None]
    n_m, k = mac_by_m.shape
    labels = list(labels) if labels is not None else [f"mode {j + 1}" for j in range(k)]
    fig = Figure(figsize=(5.5, 3.8), layout="constrained")
    ax = fig.subplots()
    m = np.arange(1, n_m + 1)
    for j in range(k):
        ax.plot(m, mac_by_m[:, j], marker="o", ms=3, label=labels[j])
    ax.axhline(mac_threshold, color="k", ls="--", lw=0.8, label=f"threshold {mac_threshold}")
    ax.axvline(n_basis, color="grey", ls=":", lw=0.8, label=f"m = {n_basis}")
    ax.set_xlabel("number of basis shapes m")
    ax.set_ylabel("MAC")
    ax.set_ylim(max(0.0, float(np.nanmin(mac_by_m)) - 0.05), 1.005)
    ax.set_xticks(m)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(title, fontsize=10)
    return fig


def plot_fit_comparison(mesh: StandardMesh, shapes: np.ndarray, fitted: np.ndarray, macs: Sequence[float]) -> Figure:
    """Original (top row) vs basis-fitted (bottom row) mode shapes [N, k] with their MACs (paper Fig. 10)."""
    shapes, fitted = np.asarray(shapes, dtype=float), np.asarray(fitted, dtype=float)
    k = shapes.shape[1]
    fig, axes = _shape_axes(2 * k, rows=2)
    for j in range(k):
        _draw_shape(axes[j], mesh, shapes[:, j], f"mode {j + 1}: original")
        _draw_shape(axes[k + j], mesh, fitted[:, j], f"fitted, MAC {macs[j]:.4f}")
    return fig


def save(fig: Figure, path: str) -> None:
    """Write a figure (format from the suffix: .png, .svg)."""
    fig.savefig(path, dpi=120)
