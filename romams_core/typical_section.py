"""2-DOF pitch-plunge typical section with R.T. Jones (Wagner) unsteady aerodynamics: a reference model.

Used to test the coupling and the flutter search independently of any 3-D solver. Coordinates
(Theodorsen): plunge h (m, positive DOWN), pitch alpha (rad, nose up) about the elastic axis at
``a`` semichords aft of mid-chord; per unit span. Semichord b, chord c = 2 b = c_ref, t* = t V / c.

Aerodynamics per unit q = 0.5 rho V^2, with ' = d/dt* (derivation in docs/flutter.md):
  L / q = (pi/2) (h'' + 2 b alpha' - a b alpha'') + 4 pi b C[W]
  M / q = 2 pi (a b / 4 h'' - b^2 / 2 (1/2 - a) alpha' - b^2 / 4 (1/8 + a^2) alpha'') + 4 pi b^2 (a + 1/2) C[W]
  W = h' / (2 b) + alpha + (1/2)(1/2 - a) alpha'   (3/4-chord downwash / V)
Generalized forces: Q_h = -L, Q_alpha = M. Jones' approximation of Theodorsen's function in the
semichord time s = 2 t*: C = 1/2 + sum_i A_i beta_i / (p + beta_i), A = (0.165, 0.335),
beta = (0.0455, 0.3); in t* the lag rates are lambda_i = 2 beta_i. Writing W = g' + alpha with
g = h / (2 b) + (1/2)(1/2 - a) alpha and lag states y_i = z_i - g removes input derivatives from the
lag equations: y_i' = -lambda_i y_i - lambda_i g + alpha, C[W] = 1/2 W + sum A_i lambda_i (y_i + g).

The discrete model (input xi = modal displacements at the sample times, as an identified ARX sees):
lag states discretized exactly for a piecewise-linear input (first-order hold, one augmented expm);
the remaining velocity and acceleration terms of the input by second-order backward differences,
u'(n) ~ (3u_n - 4u_(n-1) + u_(n-2)) / (2 dt*), u''(n) ~ (2u_n - 5u_(n-1) + 4u_(n-2) - u_(n-3)) / dt*^2,
from three stored past inputs. Truncation error O(dt*^2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from romams_core.errors import InputError
from romams_core.statespace import DiscreteSS

JONES_A = (0.165, 0.335)
JONES_BETA = (0.0455, 0.3)  # per semichord-time s = V t / b


@dataclass(frozen=True)
class TypicalSection:
    """Pitch-plunge section data: a, x_alpha, r_alpha^2 (semichord units), omega_h/omega_alpha, mu = m/(pi rho b^2).

    ``semichord_m`` (m), ``omega_alpha`` (rad/s) and ``rho`` (kg/m^3) fix the dimensional scale.
    """

    a: float = -0.2
    x_alpha: float = 0.1
    r_alpha2: float = 0.24
    omega_ratio: float = 0.4
    mu: float = 20.0
    semichord_m: float = 0.5
    omega_alpha: float = 50.0
    rho: float = 1.225

    def __post_init__(self) -> None:
        for name in ("r_alpha2", "omega_ratio", "mu", "semichord_m", "omega_alpha", "rho"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise InputError(name, f"must be finite and > 0, got {v!r}")
        if not (math.isfinite(self.a) and -1.0 <= self.a <= 1.0):
            raise InputError("a", f"must be in [-1, 1] semichords, got {self.a!r}")
        if self.r_alpha2 <= self.x_alpha**2:
            raise InputError("r_alpha2", "must exceed x_alpha^2 (positive definite mass matrix)")

    @property
    def c_ref(self) -> float:
        """Chord (m), the reference length of t*."""
        return 2.0 * self.semichord_m

    @property
    def mass(self) -> float:
        """Mass per unit span (kg/m)."""
        return self.mu * math.pi * self.rho * self.semichord_m**2


def structural_matrices(ts: TypicalSection) -> tuple[np.ndarray, np.ndarray]:
    """Mass and stiffness matrices per unit span for [h (m, down), alpha (rad)] (SI)."""
    b, m = ts.semichord_m, ts.mass
    s_a = m * ts.x_alpha * b
    i_a = m * ts.r_alpha2 * b**2
    mm = np.array([[m, s_a], [s_a, i_a]])
    kk = np.diag([m * (ts.omega_ratio * ts.omega_alpha) ** 2, i_a * ts.omega_alpha**2])
    return mm, kk


def modes(ts: TypicalSection) -> tuple[np.ndarray, np.ndarray]:
    """Natural frequencies omega [2] (rad/s, ascending) and mass-normalized mode matrix phi [2, 2]."""
    mm, kk = structural_matrices(ts)
    w2, phi = scipy.linalg.eigh(kk, mm)
    return np.sqrt(w2), phi


def jones_continuous(ts: TypicalSection) -> dict[str, np.ndarray]:
    """Continuous Jones model in t* for u = [h, alpha]: f = C y + D0 u + D1 u' + D2 u'', y' = A y + B u.

    f = [Q_h, Q_alpha] / q (m, m^2 per unit span).
    """
    a, b = ts.a, ts.semichord_m
    lam = 2.0 * np.asarray(JONES_BETA)
    amp = np.asarray(JONES_A)
    g = np.array([1.0 / (2.0 * b), 0.5 * (0.5 - a)])  # g = g . u
    e_alpha = np.array([0.0, 1.0])
    # C[W] = sum A_i lam_i y_i + (sum A_i lam_i) g.u + 1/2 alpha + 1/2 g.u'
    cw_y = amp * lam
    cw_u = cw_y.sum() * g + 0.5 * e_alpha
    cw_du = 0.5 * g
    # lift and moment factors on C[W]
    fl, fm = 4.0 * math.pi * b, 4.0 * math.pi * b**2 * (a + 0.5)
    # noncirculatory parts on u' and u''
    l_du = (math.pi / 2.0) * np.array([0.0, 2.0 * b])
    l_ddu = (math.pi / 2.0) * np.array([1.0, -a * b])
    m_du = 2.0 * math.pi * np.array([0.0, -(b**2) / 2.0 * (0.5 - a)])
    m_ddu = 2.0 * math.pi * np.array([a * b / 4.0, -(b**2) / 4.0 * (0.125 + a**2)])
    sign = np.array([-1.0, 1.0])  # Q_h = -L, Q_alpha = M
    c = sign[:, None] * np.vstack([fl * cw_y, fm * cw_y])
    d0 = sign[:, None] * np.vstack([fl * cw_u, fm * cw_u])
    d1 = sign[:, None] * np.vstack([fl * cw_du + l_du, fm * cw_du + m_du])
    d2 = sign[:, None] * np.vstack([l_ddu, m_ddu])
    a_lag = -np.diag(lam)
    b_lag = np.outer(-lam, g) + np.outer(np.ones(2), e_alpha)
    return {"A": a_lag, "B": b_lag, "C": c, "D0": d0, "D1": d1, "D2": d2}


def _foh(a: np.ndarray, b: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Exact first-order-hold step: x(n+1) = Phi x(n) + G0 u(n) + G1 u(n+1)."""
    n, m = b.shape
    big = np.zeros((n + 2 * m, n + 2 * m))
    big[:n, :n] = a * dt
    big[:n, n : n + m] = b * dt
    big[n : n + m, n + m :] = np.eye(m)
    e = scipy.linalg.expm(big)
    phi, g1, g2 = e[:n, :n], e[:n, n : n + m], e[:n, n + m :]
    return phi, g1 - g2, g2


def jones_discrete(ts: TypicalSection, dt_star: float, modal: bool = True) -> DiscreteSS:
    """Discrete aero model (A, B, C, D, dt_star) in t*; inputs/outputs modal (mass-normalized) or physical."""
    if not (math.isfinite(dt_star) and 0 < dt_star <= 1.0):
        raise InputError("dt_star", f"must be in (0, 1], got {dt_star!r}")
    ct = jones_continuous(ts)
    phi_l, g0, g1 = _foh(ct["A"], ct["B"], dt_star)
    nl, nu = ct["B"].shape
    # predictor removal: w = y - G1 u, w(n+1) = Phi w + (Phi G1 + G0) u(n), y = w + G1 u
    bw = phi_l @ g1 + g0
    dv = np.array([3.0, -4.0, 1.0, 0.0]) / (2.0 * dt_star)  # u' from u_n, u_(n-1), u_(n-2), u_(n-3)
    da = np.array([2.0, -5.0, 4.0, -1.0]) / dt_star**2
    n = nl + 3 * nu
    a = np.zeros((n, n))
    b = np.zeros((n, nu))
    a[:nl, :nl] = phi_l
    b[:nl] = bw
    b[nl : nl + nu] = np.eye(nu)  # stores u(n) as u_(n-1) of the next step
    a[nl + nu : nl + 2 * nu, nl : nl + nu] = np.eye(nu)
    a[nl + 2 * nu :, nl + nu : nl + 2 * nu] = np.eye(nu)
    deriv = [ct["D1"] * dv[i] + ct["D2"] * da[i] for i in range(4)]
    c = np.zeros((nu, n))
    c[:, :nl] = ct["C"]
    for i in range(1, 4):
        c[:, nl + (i - 1) * nu : nl + i * nu] = deriv[i]
    d = ct["C"] @ g1 + ct["D0"] + deriv[0]
    if modal:
        _, phi = modes(ts)
        b, c, d = b @ phi, phi.T @ c, phi.T @ d @ phi
    return DiscreteSS(A=a, B=b, C=c, D=d, dt_star=float(dt_star))


