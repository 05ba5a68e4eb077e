"""Euler-Bernoulli bending + St Venant torsion beam elements on the plate's (w, w_x, w_y) DOFs.

A straight element from node a to node b (in the x-y plane) has unit tangent t and in-plane
normal n = (t_y, -t_x) (for a beam along +y, n = +x, aft). Its local DOFs per node are w, the
bending slope theta = grad w . t and the section rotation phi = grad w . n (for a beam along +y,
phi = dw/dx = -alpha with alpha the nose-up twist). Bending uses cubic Hermite w, torsion linear
phi. Section inertia: mass per length m (kg/m), static moment S = m e (kg) of a centre of mass
offset e (m) along n, and rotary inertia I_phi about the beam axis per length (kg m), so the
section kinetic energy is m w'^2 + 2 S w' phi' + I_phi phi'^2 (dots in time). The beam lies on
the plate's mid-plane (no offset, no membrane coupling); the eccentric stiffener is in ``stiffener.py``.
"""

from __future__ import annotations

import numpy as np

from romams_core.errors import InputError

_GP, _GW = np.polynomial.legendre.leggauss(4)
_GP = 0.5 * (_GP + 1.0)
_GW = 0.5 * _GW


def rectangle_torsion_constant(height: np.ndarray | float, width: np.ndarray | float) -> np.ndarray:
    """St Venant torsion constant J (m^4) of a solid rectangle (series approximation, < 0.5% error)."""
    h = np.asarray(height, dtype=float)
    w = np.asarray(width, dtype=float)
    a = np.maximum(h, w)
    b = np.minimum(h, w)
    r = b / a
    return a * b**3 * (1.0 / 3.0 - 0.21 * r * (1.0 - r**4 / 12.0))


def beam_element_matrices(
    xy: np.ndarray,
    ei: np.ndarray | float,
    gj: np.ndarray | float,
    m: np.ndarray | float,
    s: np.ndarray | float,
    i_phi: np.ndarray | float,
) -> tuple[np.ndarray, np.ndarray]:
    """Element stiffness and mass [E, 6, 6] in global (w, w_x, w_y) x 2 nodes for beams [E, 2, 2] (m).

    ei, gj (N m^2), m (kg/m), s = m * offset (kg), i_phi (kg m): arrays [E] (or scalars).
    """
    xy = np.asarray(xy, dtype=float)
    ne = xy.shape[0]
    d = xy[:, 1] - xy[:, 0]
    length = np.linalg.norm(d, axis=1)
    if np.any(length <= 0.0):
        raise InputError("structure.beam_elements", "zero length")
    t = d / length[:, None]
    n = np.column_stack([t[:, 1], -t[:, 0]])
    ei, gj, m, s, i_phi = (np.broadcast_to(np.asarray(v, dtype=float), (ne,)) for v in (ei, gj, m, s, i_phi))
    big_l = length
    # local order: w_a, theta_a, phi_a, w_b, theta_b, phi_b
    xi = _GP[None, :]
    lg = big_l[:, None]
    hw = np.stack(
        [1 - 3 * xi**2 + 2 * xi**3 + 0 * lg, lg * (xi - 2 * xi**2 + xi**3), 3 * xi**2 - 2 * xi**3 + 0 * lg,
         lg * (-(xi**2) + xi**3)],
        axis=-1,
    )  # [E, G, 4]
    hpp = np.stack(
        [(-6 + 12 * xi) / lg**2, (-4 + 6 * xi) / lg, (6 - 12 * xi) / lg**2, (-2 + 6 * xi) / lg], axis=-1
    )
    nw = np.zeros((ne, _GP.size, 6))
    nw[:, :, [0, 1, 3, 4]] = hw
    npp = np.zeros((ne, _GP.size, 6))
    npp[:, :, [0, 1, 3, 4]] = hpp
    nphi = np.zeros((ne, _GP.size, 6))
    nphi[:, :, 2] = 1 - _GP
    nphi[:, :, 5] = _GP
    dphi = np.zeros(6)
    dphi[2], dphi[5] = -1.0, 1.0
    wl = _GW[None, :] * big_l[:, None]  # [E, G] integration weights, m
    k_loc = np.einsum("eg,e,egi,egj->eij", wl, ei, npp, npp) + (gj / big_l)[:, None, None] * np.outer(dphi, dphi)
    m_loc = (
        np.einsum("eg,e,egi,egj->eij", wl, m, nw, nw)
        + np.einsum("eg,e,egi,egj->eij", wl, s, nw, nphi)
        + np.einsum("eg,e,egi,egj->eij", wl, s, nphi, nw)
        + np.einsum("eg,e,egi,egj->eij", wl, i_phi, nphi, nphi)
    )
    # local = T global; per node [w, theta, phi] = [[1,0,0],[0,t],[0,n]] [w, w_x, w_y]
    tn = np.zeros((ne, 3, 3))
    tn[:, 0, 0] = 1.0
    tn[:, 1, 1:] = t
    tn[:, 2, 1:] = n
    tr = np.zeros((ne, 6, 6))
    tr[:, :3, :3] = tn
    tr[:, 3:, 3:] = tn
    k = np.einsum("eai,eab,ebj->eij", tr, k_loc, tr)
    mm = np.einsum("eai,eab,ebj->eij", tr, m_loc, tr)
    return k, mm
