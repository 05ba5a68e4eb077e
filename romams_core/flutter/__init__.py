"""Aeroelastic coupling of a discrete-time aerodynamic ROM with modal structural dynamics; flutter search.

Structure (mass-normalized modes, M = I): xi'' + G xi' + K xi = q F, K = diag(omega^2), G = diag(2 zeta omega),
q = 0.5 rho V^2 (Pa), F = f (generalized force per unit q). The aerodynamic model is a discrete state space in
nondimensional time t* = t V / c_ref with step dt_star (x(n+1) = A x + B xi, f = C x + D xi), already in real
modal coordinates (u = xi). Two couplings: ``"tustin"`` (default; bilinear map to continuous time, second order
in dt_star) and ``"zoh"`` (exact zero-order-hold structure, discrete coupling, first order). Damping: zeta =
-Re(s)/|s| (positive = stable), g = 2 Re(s)/|s| (positive = unstable); omega = Im(s) (rad/s).

Modules:

- ``inputs``: input checks (SWEEPS, COUPLINGS, check_flutter_inputs, the aero model's shapes);
- ``model``: aero preparation (cached per ROM), the Tustin / zero-order-hold coupled model;
- ``eigen``: batched eigen-solves with structural vectors and structural content;
- ``newton``: Newton roots of det T(s), many requests iterated together;
- ``sweeps``: the constant-density, constant-speed and matched parametrizations p -> (V, rho);
- ``tracking``: continuation of the structural branches with adaptive refinement and lag-root rejection;
- ``continuation``: the branches continued by Newton on det T(s) between few eigen-solves (the default where
  compiled); ``newton_kernel``: its compiled steps, Newton roots and null vectors;
- ``crossing``: the first Re(s) = 0 crossing on a structural branch, refined with brentq;
- ``point``: modal shares, SDOFF single-mode check, frequency separation;
- ``result``: FlutterResult; ``analysis``: flutter_analysis and flutter_batch (many designs at one Mach);
- ``batch``: runs many searches together, one batched eigen-solve per sweep step.

The algorithm is documented in docs/flutter.md.
"""

from romams_core.validation import finite_positive

from .analysis import flutter_analysis, flutter_batch
from .inputs import COUPLINGS, SWEEPS, check_flutter_inputs
from .model import tustin_to_continuous
from .result import FlutterResult
from .sweeps import DEFAULT_ALTITUDE_REF_M

__all__ = [
    "COUPLINGS",
    "DEFAULT_ALTITUDE_REF_M",
    "SWEEPS",
    "FlutterResult",
    "check_flutter_inputs",
    "finite_positive",
    "flutter_analysis",
    "flutter_batch",
    "tustin_to_continuous",
]
