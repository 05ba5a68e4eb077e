"""External CFD in the time domain (the ROM-AMS paper's way): the excitation a training would give a built-in solver
is written out for a CFD engineer, the generalized aerodynamic coefficients (GAC) their code computes come back, and
the ARX ROM is identified from them exactly as from a built-in solver's run.

The excitation is ``romams_core.signals.excitation_signals`` of the training settings (deterministic from the seed),
run as one continued record from rest: the training half, then the validation half ([2 n_steps, m]). The GAC
returned are f_i(t_n) = (1/q) * integral(dp * phi_i dS) (m^3, dp positive up) at the same samples
(``romams_core.aero.protocol``). ``RecordedSolver`` replays them behind the solver protocol after checking that it
is asked for exactly the exported excitation, so ``train_rom`` needs no other path.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from romams_core.aero.protocol import ProgressFn, SolverInfo
from romams_core.errors import InputError
from romams_core.mesh import StandardMesh
from romams_core.signals import excitation_signals
from romams_core.training import default_n_steps

#: training settings an external run is defined by (the keyword arguments of ``train_rom`` that shape the signals)
SIGNAL_SETTINGS = ("n_steps", "dt_star", "k_max", "seed", "displacement_fraction")
#: largest GAC record accepted (samples x shapes)
MAX_GAC_ENTRIES = 20_000_000


def signal_settings(mesh: StandardMesh, n_shapes: int, na: int = 8, nb: int = 8, k_max: float = 1.5,
                    n_steps: int | None = None, dt_star: float | None = None, seed: int = 0,
                    displacement_fraction: float = 0.01) -> dict[str, Any]:
    """The signal settings with ``train_rom``'s defaults filled in (dt* = 1 / n_chord, the default length)."""
    dt = 1.0 / mesh.n_chord if dt_star is None else float(dt_star)
    n = default_n_steps(n_shapes, na, nb, dt, k_max) if n_steps is None else int(n_steps)
    return {"n_steps": n, "dt_star": dt, "k_max": float(k_max), "seed": int(seed),
            "displacement_fraction": float(displacement_fraction)}


def excitation(mesh: StandardMesh, shapes: np.ndarray, settings: dict[str, Any]) -> np.ndarray:
    """[2 n_steps, m] generalized displacements (training then validation half) of ``settings`` for ``shapes``."""
    exc = excitation_signals(shapes, mesh.c_ref, int(settings["n_steps"]), float(settings["dt_star"]),
                             k_max=float(settings["k_max"]), seed=int(settings["seed"]),
                             displacement_fraction=float(settings["displacement_fraction"]))
    return np.vstack([exc.train, exc.validation])


def check_gac(gac: Any, n_samples: int, n_shapes: int) -> np.ndarray:
    """The returned GAC as float [n_samples, n_shapes] (InputError naming ``gac`` otherwise)."""
    try:
        arr = np.asarray(gac, dtype=float)
    except (TypeError, ValueError):
        raise InputError("gac", "must be an array of numbers") from None
    if arr.size > MAX_GAC_ENTRIES:
        raise InputError("gac", f"too large: {arr.size} values (at most {MAX_GAC_ENTRIES})")
    if arr.shape != (n_samples, n_shapes):
        what = "time steps" if arr.ndim == 2 and arr.shape[1] == n_shapes else "shape"
        raise InputError("gac", f"wrong {what}: expected [{n_samples}, {n_shapes}] (2 n_steps samples x basis "
                                f"shapes), got {list(arr.shape)}")
    if not np.all(np.isfinite(arr)):
        raise InputError("gac", "must be finite (no NaN or infinity)")
    dead = np.flatnonzero(np.max(np.abs(arr), axis=0) == 0.0)
    if dead.size:
        raise InputError("gac", f"column {int(dead[0])} is zero at every sample: no aerodynamic response")
    return arr


@dataclass
class RecordedSolver:
    """GAC computed elsewhere for one excitation, behind the UnsteadySolver protocol: ``simulate`` returns them when
    asked for that excitation (to 1e-12 relative) and refuses anything else."""

    signals: np.ndarray  # [T, m] the exported excitation
    gac: np.ndarray  # [T, m] the returned GAC (m^3)
    mach: float
    name: str = "external"
    source: str = "GAC time histories of an external CFD run"
    warnings: list[str] = field(default_factory=list)

    def info(self, mach: float) -> SolverInfo:
        """Description and warnings."""
        return SolverInfo(name=self.name, description=f"{self.source} at M {self.mach:g}",
                          warnings=list(self.warnings))

    def simulate(self, mesh: StandardMesh, shapes: np.ndarray, signals: np.ndarray, mach: float, dt_star: float,
                 progress: ProgressFn | None = None) -> np.ndarray:
        """The recorded GAC [T, m] for exactly the recorded ``signals`` at the recorded Mach."""
        s = np.asarray(signals, dtype=float)
        if abs(float(mach) - self.mach) > 1e-9:
            raise InputError("mach", f"the GAC were computed at M {self.mach:g}, not {float(mach):g}")
        scale = float(np.max(np.abs(self.signals))) or 1.0
        if s.shape != self.signals.shape or float(np.max(np.abs(s - self.signals))) > 1e-12 * scale:
            raise InputError("signals", "the training asks for another excitation than the exported one (its "
                                        "settings differ)")
        if progress is not None:
            progress(1.0, "recorded GAC read")
        return self.gac.copy()
