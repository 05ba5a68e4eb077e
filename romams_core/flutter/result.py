"""The result of one flutter search (:class:`FlutterResult`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .curves import VgCurves


@dataclass
class FlutterResult:
    """Flutter point and V-g / V-omega data of one Mach number (SI units, rad/s).

    Flutter point (scalars; None when no flutter was found in the sweep range):

    - ``v_flutter_m_s``: TRUE airspeed at the flutter point, for every sweep (for the constant-speed sweep
      this is always M a_ref). ``v_true_m_s`` is the same value (kept for older readers).
    - ``v_eas_m_s``: equivalent airspeed sqrt(2 q_f / rho_0), rho_0 the ISA sea-level density (1.225 kg/m^3).
      It orders flutter points by dynamic pressure and is what compares designs in a constant-speed sweep.
    - ``q_flutter_pa``, ``rho_flutter``, ``omega_flutter_rad_s`` (|Im s|), ``k_flutter`` = omega_f (c_ref / 2) /
      V_true (reduced frequency on the root semichord), ``altitude_m`` (matched sweep only),
      ``flutter_mode`` (1-based structural mode the flutter branch starts from at q = 0).
    - ``sdoff``, ``energy_share``, ``single_mode_unstable``, ``frequency_separation``: see docs/flutter.md.

    Reference state: ``rho_ref`` (kg/m^3), ``a_ref`` (m/s) and ``altitude_ref_m``, the ISA altitude they were
    taken from (None when rho_ref and a_ref were both given explicitly).

    V-g data over the sweep points [nv] (branch data [nv, k]): ``v`` is the sweep's speed axis -- true speed
    for the constant-density and matched sweeps, the speed sqrt(2 q / rho_ref) for the constant-speed sweep
    (so its plot has a varying axis; the true speed there is constant); ``v_eas`` = sqrt(2 q / rho_0) for every
    sweep; ``q``, ``rho``, ``altitude`` (NaN unless matched). ``g`` = 2 Re(s)/|s| (positive = unstable),
    ``zeta`` = -Re(s)/|s| (positive = stable), ``omega`` = Im(s) (rad/s). ``modal_share`` [k]: modal shares of
    the flutter eigenvector. ``lag_root_flagged``: True when a tracked branch had to be continued on an
    aerodynamic lag root because no structural candidate was left (never seen in practice; the message says so).
    ``outside_band``: True when the flutter point's reduced frequency is above the band the ROM was identified
    in (``k_band`` of flutter_analysis); the message then carries a warning. ``unstable_above_band_v_m_s``: in a
    constant-density sweep with ``k_band``, an unstable run of a branch that stays above the band and ends is not
    counted as flutter (the sweep's start at V -> 0 is outside every ROM's band, docs/flutter.md 9.10); this is
    the highest speed of such runs before the flutter point (None: none), and the message notes it. ``curves``:
    the plot's V-g / V-f curves from q = 0 (wind-off frequencies first), with every tracked point and extra
    points near each crossing (``curves.VgCurves``; None in results stored before they existed).
    """

    mach: float
    sweep: str
    coupling: str
    flutter_found: bool
    v_flutter_m_s: float | None  # true airspeed at the flutter point
    omega_flutter_rad_s: float | None
    q_flutter_pa: float | None
    rho_flutter: float | None
    altitude_m: float | None
    k_flutter: float | None  # omega_f * (c_ref / 2) / V_true: reduced frequency on the root semichord
    v_true_m_s: float | None  # physical speed at the flutter point (= v_flutter_m_s)
    flutter_mode: int | None  # 1-based index of the structural mode the flutter branch starts from
    sdoff: bool
    energy_share: float | None  # largest modal share of the flutter eigenvector ([xi; xi'/omega] norm)
    frequency_separation: float | None  # min relative frequency gap to another structural branch (info)
    single_mode_unstable: bool  # dominant mode alone unstable at q <= sdoff_q_factor q_f (checked if share high)
    message: str
    rho_ref: float
    a_ref: float
    c_ref: float
    dt_star: float
    v: np.ndarray = field(default_factory=lambda: np.zeros(0))  # [nv] m/s, the sweep's speed axis (see above)
    q: np.ndarray = field(default_factory=lambda: np.zeros(0))  # [nv] Pa
    rho: np.ndarray = field(default_factory=lambda: np.zeros(0))  # [nv] kg/m^3
    altitude: np.ndarray = field(default_factory=lambda: np.zeros(0))  # [nv] m (NaN unless matched)
    g: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))  # [nv, k]
    zeta: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))  # [nv, k]
    omega: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))  # [nv, k] rad/s
    modal_share: np.ndarray = field(default_factory=lambda: np.zeros(0))  # [k] shares of the flutter vector
    v_eas_m_s: float | None = None  # equivalent airspeed sqrt(2 q_f / rho_0) at the flutter point
    altitude_ref_m: float | None = None  # ISA altitude of rho_ref / a_ref (None: both given explicitly)
    v_eas: np.ndarray = field(default_factory=lambda: np.zeros(0))  # [nv] m/s, sqrt(2 q / rho_0)
    lag_root_flagged: bool = False  # a branch was continued on an aero lag root (no structural candidate)
    outside_band: bool = False  # k_flutter above the ROM's identified band (k_band): the ROM is not valid there
    unstable_above_band_v_m_s: float | None = None  # constant density: highest V below the flutter point where a
    # branch was unstable above the band (k > k_band) and so not counted (docs/flutter.md 9.10)
    curves: VgCurves | None = None  # plot-only V-g / V-f curves from q = 0, refined near crossings (curves.py)


def no_flutter_fields() -> dict[str, Any]:
    """The flutter-point fields of a result without a flutter point (all None / False)."""
    return dict(
        flutter_found=False, v_flutter_m_s=None, omega_flutter_rad_s=None, q_flutter_pa=None, rho_flutter=None,
        altitude_m=None, k_flutter=None, v_true_m_s=None, v_eas_m_s=None, flutter_mode=None, sdoff=False,
        energy_share=None, frequency_separation=None, single_mode_unstable=False,
    )
