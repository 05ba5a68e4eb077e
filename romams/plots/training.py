"""Figures of a ROM training run: excitation signals (paper Fig. 12), solver vs ROM on validation (Fig. 13),
and for a rational-function ROM the solver's GAF table against the fit."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from matplotlib.figure import Figure


def _stack(n: int, width: float = 7.5, height: float = 1.25) -> tuple[Figure, np.ndarray]:
    """A figure with n stacked axes sharing the time axis."""
    fig = Figure(figsize=(width, max(2.5, height * n + 0.8)), layout="constrained")  # no pyplot: thread-safe
    axes = fig.subplots(n, 1, sharex=True, squeeze=False)[:, 0]
    return fig, axes


def plot_signals(rom: Any, which: str = "train") -> Figure:
    """Generalized-displacement excitation u_i(t*) of every basis shape (training or validation signal)."""
    sig = np.asarray(rom.signals_train if which == "train" else rom.signals_validation)
    t = np.arange(sig.shape[0]) * rom.dt_star
    fig, axes = _stack(sig.shape[1])
    for i, ax in enumerate(axes):
        ax.plot(t, sig[:, i], lw=0.6, color="C0")
        ax.set_ylabel(f"u{i + 1}", rotation=0, labelpad=12, fontsize=8)
        ax.tick_params(labelsize=7)
    axes[-1].set_xlabel("t* = t V / c_ref")
    fig.suptitle(f"{which} excitation of {sig.shape[1]} shapes, k <= {rom.k_max:g} (M = {rom.mach:g})", fontsize=10)
    return fig


def plot_validation(rom: Any, window: float | None = 60.0) -> Figure:
    """Solver GAC f_i(t*) vs the ROM's free-run prediction on the validation signal, with NRMSE per output."""
    ref = np.asarray(rom.gac_validation)
    pred = np.asarray(rom.predicted_validation)
    t = np.arange(ref.shape[0]) * rom.dt_star
    if window is not None:  # a readable excerpt after the taper
        t0 = min(t[-1], 10.0)
        sel = (t >= t0) & (t <= t0 + window)
    else:
        sel = slice(None)
    fig, axes = _stack(ref.shape[1])
    for i, ax in enumerate(axes):
        ax.plot(t[sel], ref[sel, i], lw=1.4, color="0.6", label=f"{rom.solver} (direct)")
        ax.plot(t[sel], pred[sel, i], lw=0.8, ls="--", color="C3", label="ROM (ARX)")
        err = float(rom.validation_nrmse[i])
        ax.set_ylabel(f"f{i + 1}", rotation=0, labelpad=12, fontsize=8)
        ax.text(0.99, 0.9, f"NRMSE {err:.1e}" if math.isfinite(err) else "NRMSE n/a", transform=ax.transAxes,
                ha="right", va="top", fontsize=7)
        ax.tick_params(labelsize=7)
    axes[0].legend(fontsize=7, loc="upper left", ncol=2)
    axes[-1].set_xlabel("t* = t V / c_ref")
    fig.suptitle(f"validation: GAC of {ref.shape[1]} shapes (M = {rom.mach:g}, na = {rom.na}, nb = {rom.nb}, "
                 f"{rom.ss.n_states} states)", fontsize=10)
    return fig


def plot_rfa_fit(rom: Any, entries: int = 4) -> Figure:
    """Real and imaginary parts of the diagonal GAF H_ii(k) of the first ``entries`` shapes: table vs RFA fit."""
    k = np.asarray(rom.k_values)
    kk = np.linspace(0.0, float(k[-1]) * 1.25, 200)
    fit = rom.rfa(kk)
    n = min(entries, rom.n_basis)
    fig = Figure(figsize=(7.5, max(2.5, 1.6 * n + 0.8)), layout="constrained")
    axes = fig.subplots(n, 2, sharex=True, squeeze=False)
    for i in range(n):
        for j, (part, name) in enumerate(((np.real, "Re"), (np.imag, "Im"))):
            ax = axes[i, j]
            ax.plot(k, part(rom.gaf[:, i, i]), "o", ms=3, color="C0", label=rom.solver)
            ax.plot(kk, part(fit[:, i, i]), lw=1.0, color="C1", label=f"RFA ({rom.n_lags} lags)")
            ax.set_ylabel(f"{name} H{i + 1}{i + 1}", fontsize=8)
            ax.tick_params(labelsize=7)
            ax.set_title(f"entry error {rom.fit_error[i, i]:.1e}", fontsize=7)
    axes[0, 0].legend(fontsize=7)
    for ax in axes[-1]:
        ax.set_xlabel("k = omega b / V")
    fig.suptitle(f"{rom.solver} GAF and its RFA (M = {rom.mach:g}, worst entry error {rom.max_fit_error:.1e})",
                 fontsize=10)
    return fig


def save(fig: Figure, path: str) -> None:
    """Write a figure (format from the suffix: .png, .svg)."""
    fig.savefig(path, dpi=120)
