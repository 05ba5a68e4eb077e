"""Cross-check of a time-domain (UVLM) ROM's aerodynamic damping against the doublet lattice.

The damping a shape receives from the air is the imaginary part of its diagonal GAC, Im H_ii(k) (negative =
damped, with the e^{i omega t} convention of both solvers). For a chordwise-bending shape it is a few per cent of
|H_ii|, so a phase error of a few degrees changes its sign. The UVLM's is too small for two reasons
(docs/aerodynamics.md, section 11): its vortex lattice converges slowly in that small out-of-phase part (the
cropped delta's 4th mode at M 0.01, k = 0.96: +0.26, -0.05, -0.16 for lattices refined 1, 2, 3 times, against
-0.69 from the DLM at every refinement), and its quasi-steady compressibility has no acoustic retardation (the
same mode at M 0.87: -0.34 against -11.8). Shapes that the doublet lattice damps clearly but the UVLM ROM damps
by less than a quarter as much (or not at all) are flagged: the UVLM cannot resolve them.
"""

from __future__ import annotations

import numpy as np

from romams_core.mesh import StandardMesh

#: Reduced frequencies (semichord) of the check, where flutter and the chordwise-bending modes of model wings lie.
CHECK_K = (0.3, 0.6, 1.0)
#: The DLM damping must exceed this share of |H_ii| for a disagreement to count.
MIN_DAMPING_SHARE = 0.02
#: A ROM damping below this fraction of the DLM's is a disagreement.
MIN_DAMPING_RATIO = 0.25


def damping_disagreements(h: np.ndarray, h_ref: np.ndarray, k: np.ndarray, min_share: float = MIN_DAMPING_SHARE,
                          min_ratio: float = MIN_DAMPING_RATIO) -> list[tuple[int, float, complex, complex]]:
    """(shape, k, H_ii, H_ref_ii) where the reference damps (Im H_ref_ii < -min_share |H_ref_ii|) and the ROM
    gives less than ``min_ratio`` of that damping (Im H_ii > min_ratio Im H_ref_ii, zero or negative included)."""
    d = np.diagonal(h, axis1=1, axis2=2)
    d_ref = np.diagonal(h_ref, axis1=1, axis2=2)
    bad = (d_ref.imag < -min_share * np.abs(d_ref)) & (d.imag > min_ratio * d_ref.imag)
    rows, cols = np.nonzero(bad)
    return [(int(i), float(k[n]), complex(d[n, i]), complex(d_ref[n, i])) for n, i in zip(rows, cols, strict=True)]


def uvlm_damping_warnings(mesh: StandardMesh, shapes: np.ndarray, mach: float, rom_freqresp: np.ndarray,
                          k: np.ndarray, reference: object | None = None, symmetry: str = "symmetric") -> list[str]:
    """Warnings naming the shapes whose ROM damping (``rom_freqresp`` [nk, m, m] at k) the DLM contradicts.

    ``reference``: a frequency-domain solver (default: the DLM on the unrefined lattice, whose damping terms are
    within a few per cent of the refined one's, at a tenth of the cost, with the ROM's root ``symmetry``).
    """
    if reference is None:
        from romams_core.aero.dlm import DlmSolver

        reference = DlmSolver(refine=1, symmetry=symmetry)
    h_ref = np.asarray(reference.gaf(mesh, shapes, mach, np.asarray(k, float)))  # type: ignore[attr-defined]
    out = []
    by_shape: dict[int, list[tuple[float, complex, complex]]] = {}
    for i, kk, hv, hr in damping_disagreements(np.asarray(rom_freqresp), h_ref, np.asarray(k, float)):
        by_shape.setdefault(i, []).append((kk, hv, hr))
    for i, rows in sorted(by_shape.items()):
        where = ", ".join(f"k = {kk:g}: Im H = {hv.imag:+.3g} vs DLM {hr.imag:+.3g}" for kk, hv, hr in rows)
        out.append(f"shape {i + 1}: the UVLM ROM damps it by less than {MIN_DAMPING_RATIO:g} of the doublet lattice's "
                   f"aerodynamic damping ({where}); the vortex lattice does not resolve this shape's unsteady "
                   "chordwise pressure (docs/aerodynamics.md, section 11): use solver 'dlm'")
    return out
