"""Excitation signals for ROM training: band-limited, mutually uncorrelated, tapered, seeded.

Time is nondimensional, t* = t V / c_ref, sampled with step dt_star. Reduced frequency k is on the
root semichord b = c_ref / 2 (k = omega b / V), so a component of reduced frequency k has angular
frequency 2 k per unit t*.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from romams_core.errors import InputError
from romams_core.validation import check_number

__all__ = ["Excitation", "multisine", "excitation_signals", "displacement_amplitude", "cross_correlation"]


@dataclass
class Excitation:
    """Training and validation signals [T, m] (generalized displacements, dimensionless) and how they were made."""

    train: np.ndarray
    validation: np.ndarray
    dt_star: float
    k_max: float
    seed: int
    max_displacement: float  # m, largest |sum_i u_i phi_i| over nodes and time (both realizations)


def _taper(n_steps: int, n_taper: int) -> np.ndarray:
    """Raised-cosine window [n_steps] rising over the first and falling over the last n_taper samples."""
    w = np.ones(n_steps)
    if n_taper > 0:
        ramp = 0.5 * (1.0 - np.cos(math.pi * np.arange(n_taper) / n_taper))
        w[:n_taper] = ramp
        w[n_steps - n_taper :] = ramp[::-1]
    return w


def multisine(
    n_steps: int, n_signals: int, dt_star: float, k_max: float, rng: np.random.Generator, taper_chords: float = 5.0,
    low_k_corner: float = 0.0,
) -> np.ndarray:
    """Random-phase multisines [T, m] on 0 < k <= k_max, tapered, then made exactly orthonormal.

    Line amplitudes sqrt(1 + low_k_corner / k): a flat spectrum for ``low_k_corner`` 0, else the power below the
    corner (reduced frequency on the root semichord) raised as 1 / k, so the few lines a record resolves at low k
    carry more of the signal.

    Orthogonalization (symmetric, S^-1/2) mixes the columns linearly, so the result stays band-limited and
    tapered while its columns have zero mutual inner product; each column has unit RMS.
    """
    if not (isinstance(n_steps, int | np.integer) and n_steps >= 16):
        raise InputError("n_steps", f"must be an integer >= 16, got {n_steps!r}")
    if not (isinstance(n_signals, int | np.integer) and n_signals >= 1):
        raise InputError("n_signals", f"must be an integer >= 1, got {n_signals!r}")
    if not (math.isfinite(k_max) and k_max > 0):
        raise InputError("k_max", f"must be a finite number > 0, got {k_max!r}")
    omega = 2.0 * math.pi * np.fft.rfftfreq(n_steps, d=dt_star)  # rad per unit t*
    band = (omega > 0) & (omega <= 2.0 * k_max)
    n_band = int(band.sum())
    if n_band < n_signals + 2:
        raise InputError(
            "n_steps", f"{n_steps} steps of dt_star = {dt_star:g} resolve only {n_band} frequencies up to "
            f"k_max = {k_max:g}; need more than {n_signals + 2}"
        )
    if 2.0 * k_max * dt_star >= math.pi:
        raise InputError("dt_star", f"{dt_star:g} cannot resolve k_max = {k_max:g} (2 k dt* must be < pi)")
    check_number("low_k_corner", low_k_corner, 0.0, strict=False, upper=float(k_max), upper_strict=False)
    spec = np.zeros((omega.size, n_signals), dtype=complex)
    amplitude = np.sqrt(1.0 + low_k_corner / (0.5 * omega[band]))
    spec[band] = amplitude[:, None] * np.exp(2j * math.pi * rng.random((n_band, n_signals)))
    x = np.fft.irfft(spec, n=n_steps, axis=0)
    n_taper = min(n_steps // 4, int(round(taper_chords / dt_star)))
    x *= _taper(n_steps, n_taper)[:, None]
    s = x.T @ x
    evals, evecs = np.linalg.eigh(s)
    x = x @ (evecs / np.sqrt(evals)) @ evecs.T  # S^-1/2: columns orthonormal
    return x * math.sqrt(n_steps)  # unit RMS


def displacement_amplitude(shapes: np.ndarray, signals: np.ndarray) -> float:
    """Largest surface displacement max_t max_node |sum_i u_i(t) phi_i| (units of shapes, m)."""
    return float(np.abs(np.asarray(shapes) @ np.asarray(signals).T).max())


def excitation_signals(
    shapes: np.ndarray,
    c_ref: float,
    n_steps: int,
    dt_star: float,
    k_max: float = 1.5,
    seed: int = 0,
    displacement_fraction: float = 0.01,
    low_k_corner: float = 0.0,
) -> Excitation:
    """Training and independent validation signals [T, m] for shapes [N, m] (m); peak displacement ~ fraction c_ref
    (``low_k_corner``: see ``multisine``)."""
    shapes = np.asarray(shapes, dtype=float)
    if shapes.ndim != 2:
        raise InputError("shapes", f"expected [N, m], got shape {shapes.shape}")
    if not (math.isfinite(c_ref) and c_ref > 0):
        raise InputError("c_ref", f"must be a finite number > 0, got {c_ref!r}")
    if not (0 < displacement_fraction < 0.2):
        raise InputError("displacement_fraction", f"must be in (0, 0.2), got {displacement_fraction!r}")
    m = shapes.shape[1]
    train = multisine(n_steps, m, dt_star, k_max, np.random.default_rng([seed, 0]), low_k_corner=low_k_corner)
    val = multisine(n_steps, m, dt_star, k_max, np.random.default_rng([seed, 1]), low_k_corner=low_k_corner)
    peak = max(displacement_amplitude(shapes, train), displacement_amplitude(shapes, val))
    if not peak > 0:
        raise InputError("shapes", "all-zero shapes cannot be excited")
    scale = displacement_fraction * c_ref / peak
    return Excitation(
        train=train * scale,
        validation=val * scale,
        dt_star=float(dt_star),
        k_max=float(k_max),
        seed=int(seed),
        max_displacement=displacement_fraction * c_ref,
    )


def cross_correlation(signals: np.ndarray) -> np.ndarray:
    """Normalized zero-lag correlation matrix [m, m] of signals [T, m] (inner products over RMS products)."""
    x = np.asarray(signals, dtype=float)
    s = x.T @ x
    d = np.sqrt(np.diag(s))
    return s / np.outer(d, d)
