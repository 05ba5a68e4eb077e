"""Figures of structural mode shapes: FE contour on the planform and the mapped standard-mesh shape."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.tri import Triangulation

from romams.plots.planform import CMAP, colorbar, decorate
from romams_core.mesh import StandardMesh
from romams_core.structure.modal import ModalResult


def plot_modes(modal: ModalResult, mesh: StandardMesh, title: str = "") -> Figure:
    """Mode shapes (w, normalized per mode) on the planform: FE field where available, standard-mesh nodes on top."""
    k = modal.n_modes
    cols = min(k, 4)
    rows = math.ceil(k / cols)
    fig = Figure(figsize=(3.2 * cols, 3.0 * rows + 0.4), layout="constrained")  # no pyplot (thread safe)
    axes = fig.subplots(rows, cols, squeeze=False).ravel()
    for ax in axes[k:]:
        ax.set_visible(False)
    for m, ax in enumerate(axes[:k]):
        w = modal.shapes[:, m]
        lim = float(np.max(np.abs(w))) or 1.0
        if modal.fe_triangles.size:
            tri = Triangulation(modal.fe_xy[:, 1], modal.fe_xy[:, 0], modal.fe_triangles)
            ax.tricontourf(tri, np.clip(modal.fe_shapes[:, m] / lim, -1, 1), levels=np.linspace(-1, 1, 21),
                           cmap=CMAP)
            ax.triplot(tri, color="0.6", lw=0.2)
        else:
            ax.pcolormesh(mesh.grid(mesh.y), mesh.grid(mesh.x), mesh.grid(w) / lim, shading="gouraud",
                          cmap=CMAP, vmin=-1, vmax=1)
            ax.plot(modal.fe_xy[:, 1], modal.fe_xy[:, 0], "k.-", ms=2, lw=0.6)
        ax.scatter(mesh.y, mesh.x, c=w / lim, cmap=CMAP, vmin=-1, vmax=1, s=8, edgecolors="k", linewidths=0.2)
        decorate(ax, np.concatenate([mesh.y, modal.fe_xy[:, 1]]), np.concatenate([mesh.x, modal.fe_xy[:, 0]]))
        ax.set_title(f"mode {m + 1}: {modal.frequencies_hz[m]:.2f} Hz", fontsize=9)
    colorbar(fig, axes[:k])
    if title:
        fig.suptitle(f"{title}  (mass {modal.mass_kg:.4f} kg, {modal.n_fe_nodes} FE nodes)", fontsize=10)
    return fig


def save_mode_plots(modal: ModalResult, mesh: StandardMesh, out_dir: str | Path, title: str = "") -> list[Path]:
    """Write modes.png into out_dir (created) and return the file paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "modes.png"
    plot_modes(modal, mesh, title).savefig(path, dpi=120)
    return [path]
