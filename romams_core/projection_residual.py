"""Linear (DLM) correction of what a structure's modes hold outside the basis span (ROM-AMS projection residual).

ROM-AMS moves a structure's modes Phi through the basis: the basis ROM sees the fitted shapes Phi_fit = V gamma,
so its modal GAF is exactly G(Phi_fit). The residual Phi - Phi_fit is small in displacement (MAC 0.9999 and up),
but its chordwise slope, which sets the downwash, need not be: at the paper case's TSD optimum (M 0.95) the TSD's
own transfer matrix of the fitted shapes is 3 % of the largest entry off that of the modes, and the flutter
speed of an exact ROM-AMS 1.3 % high (docs/transonic.md 7.12).

The residual's aerodynamics is taken from the doublet-lattice method, which is linear in the shape like every
ROM here:

    dG(k) = G_dlm(Phi, k) - G_dlm(Phi_fit, k)

at a few reduced frequencies, and added to the modal ROM by the parallel lag realization of the anchors
(``anchors.with_lag_terms``: the corrected model reproduces G_rom + dG exactly at those k). On the paper case's
optimum the TSD's residual and the DLM's agree to 0.09 % of the largest entry (flutter +0.15 % of the TSD point
instead of +1.32 %).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from romams_core.aero.dlm import frequency_response
from romams_core.anchors import SS, with_lag_terms
from romams_core.mesh import StandardMesh

__all__ = ["PROJECTION_CORRECTIONS", "RESIDUAL_K", "ResidualCorrection", "residual_gaf"]

#: the evaluation's choices: auto (the DLM's residual on TSD ROMs, none on the linear solvers' ROMs), none, dlm
PROJECTION_CORRECTIONS = ("auto", "none", "dlm")
#: reduced frequencies (on c_ref / 2) where the correction is exact. Fitted on the paper case's optimum at M 0.95:
#: the lag realization through 0.05 / 0.1 / 0.3 stays within 0.47 % of the largest entry of the residual over
#: k 0-0.5 (0.025 / 0.05 / 0.1: 0.85 %; one anchor at 0.1: 1.5 %)
RESIDUAL_K = (0.05, 0.1, 0.3)


def residual_gaf(mesh: StandardMesh, shapes: np.ndarray, fitted: np.ndarray, mach: float, k: np.ndarray,
                 symmetry: str = "symmetric") -> np.ndarray:
    """DLM GAF [nk, n, n] (m^3) of the modes ``shapes`` [N, n] (m) minus that of their basis fits ``fitted``."""
    n = shapes.shape[1]
    g = frequency_response(mesh, np.hstack([shapes, fitted]), mach, np.asarray(k, dtype=float), symmetry=symmetry)
    return g[:, :n, :n] - g[:, n:, n:]


@dataclass(frozen=True)
class ResidualCorrection:
    """The DLM residual correction of one wing (standard mesh and root symmetry) at ``k`` (on c_ref / 2)."""

    mesh: StandardMesh
    symmetry: str = "symmetric"
    k: Sequence[float] = RESIDUAL_K

    def apply(self, ss_modal: SS, shapes: np.ndarray, fitted: np.ndarray, mach: float) -> SS:
        """The modal ROM ``ss_modal`` (discrete or continuous; inputs/outputs: the modes) plus the residual's DLM
        GAF, by lag states (``anchors.with_lag_terms``)."""
        k = np.asarray(self.k, dtype=float)
        return with_lag_terms(ss_modal, k, residual_gaf(self.mesh, shapes, fitted, mach, k, self.symmetry))
