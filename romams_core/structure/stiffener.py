"""Stiffening beam attached off the plate mid-plane (rigid offset link), on the flat-shell DOFs.

Shell DOFs per node (6): w (m), w_x, w_y (rad), u, v (m), theta_z (rad), in the global axes. A
straight beam element a -> b has unit tangent t and in-plane normal n = (t_y, -t_x); per node its
local DOFs are w, theta = t.grad w, phi = n.grad w, u_s = t.(u, v), v_n = n.(u, v), theta_z.

The beam centroid sits at height e (m, signed; e = 0: on the mid-plane) above the plate
mid-plane and is rigidly linked to the plate's normal (Kirchhoff): the centroid's in-plane
displacement is (u, v) - e grad w, so along the beam

    u_c = u_s - e dw/ds,   v_c = v_n - e phi,   axial strain eps = du_s/ds - e d2w/ds2.

Strain energy per length: EA eps^2 + EI w''^2 + GJ phi'^2 (halved), with EI about the beam's own
centroid; expanding EA eps^2 gives the offset term EA e^2 w''^2 and the coupling -2 EA e u_s' w''
with the plate membrane, so the plate + beam section bends about its composite neutral axis.
Kinetic energy per length: m (w'^2 + u_c'^2 + v_c'^2) + I_phi phi'^2 (dots in time), m = rho A and
I_phi the polar rotary inertia of the section about its centroid; the offset adds m e^2 to the
rotary inertia of both the bending slope and the twist. w is cubic Hermite, u_s, v_n and phi
linear (u_s linear matches the Allman side's tangential displacement, so beam and plate stay
compatible along the line); 4-point Gauss integrates every term exactly. Not modelled: the
beam's in-plane (lateral) bending stiffness (the plate's membrane is far stiffer in that
direction) and warping.
"""

from __future__ import annotations

import numpy as np

from romams_core.errors import InputError

_GP, _GW = np.polynomial.legendre.leggauss(4)
_GP = 0.5 * (_GP + 1.0)
_GW = 0.5 * _GW

SHELL_DOFS = 6  # w, w_x, w_y, u, v, theta_z per node


def _hermite(length: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Cubic Hermite w, dw/ds, d2w/ds2 rows [E, G, 4] on (w_a, theta_a, w_b, theta_b) at the Gauss points."""
    xi = _GP[None, :]
    lg = length[:, None]
    one = np.ones_like(lg)
    h = np.stack([(1 - 3 * xi**2 + 2 * xi**3) * one, lg * (xi - 2 * xi**2 + xi**3), (3 * xi**2 - 2 * xi**3) * one,
                  lg * (-(xi**2) + xi**3)], axis=-1)
    hp = np.stack([(-6 * xi + 6 * xi**2) / lg, 1 - 4 * xi + 3 * xi**2 + 0 * lg, (6 * xi - 6 * xi**2) / lg,
                   -2 * xi + 3 * xi**2 + 0 * lg], axis=-1)
    hpp = np.stack([(-6 + 12 * xi) / lg**2, (-4 + 6 * xi) / lg, (6 - 12 * xi) / lg**2, (-2 + 6 * xi) / lg], axis=-1)
    return h, hp, hpp


def _local_rows(length: np.ndarray, e: np.ndarray) -> dict[str, np.ndarray]:
    """Interpolation rows [E, G, 12] in local DOFs: w, centroid u_c, v_c, phi, w'' and the axial strain."""
    ne = length.size
    h, hp, hpp = _hermite(length)
    bend = [0, 1, 6, 7]
    lin = np.stack([1 - _GP, _GP], axis=-1)[None]  # [1, G, 2]

    def rows(cols: list[int], vals: np.ndarray) -> np.ndarray:
        """[E, G, 12] with vals placed in the given local columns."""
        r = np.zeros((ne, _GP.size, 12))
        r[:, :, cols] = vals
        return r

    w, wp, wpp = rows(bend, h), rows(bend, hp), rows(bend, hpp)
    phi = rows([2, 8], np.broadcast_to(lin, (ne, _GP.size, 2)))
    us = rows([3, 9], np.broadcast_to(lin, (ne, _GP.size, 2)))
    vn = rows([4, 10], np.broadcast_to(lin, (ne, _GP.size, 2)))
    dus = rows([3, 9], np.broadcast_to(np.stack([-1 / length, 1 / length], axis=-1)[:, None], (ne, _GP.size, 2)))
    ec = e[:, None, None]
    return {"w": w, "uc": us - ec * wp, "vc": vn - ec * phi, "phi": phi, "wpp": wpp, "eps": dus - ec * wpp}


def _gram(wl: np.ndarray, coef: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """sum_g wl coef a^T b [E, 12, 12] for rows a, b [E, G, 12], weights wl [E, G] (m), coefficients [E]."""
    return np.einsum("eg,e,egi,egj->eij", wl, coef, a, b)


def _to_global(xy: np.ndarray, mat: np.ndarray) -> np.ndarray:
    """Rotate local element matrices [E, 12, 12] to the global shell DOFs of beams [E, 2, 2]."""
    d = xy[:, 1] - xy[:, 0]
    t = d / np.linalg.norm(d, axis=1)[:, None]
    n = np.column_stack([t[:, 1], -t[:, 0]])
    tn = np.zeros((xy.shape[0], 6, 6))
    tn[:, 0, 0] = tn[:, 5, 5] = 1.0
    tn[:, 1, 1:3] = tn[:, 3, 3:5] = t
    tn[:, 2, 1:3] = tn[:, 4, 3:5] = n
    tr = np.zeros((xy.shape[0], 12, 12))
    tr[:, :6, :6] = tn
    tr[:, 6:, 6:] = tn
    return np.einsum("eai,eab,ebj->eij", tr, mat, tr)


def offset_beam_matrices(
    xy: np.ndarray,
    offset: np.ndarray | float,
    ea: np.ndarray | float,
    ei: np.ndarray | float,
    gj: np.ndarray | float,
    m: np.ndarray | float,
    i_phi: np.ndarray | float,
) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness and mass [E, 12, 12] in global shell DOFs x 2 nodes for beams [E, 2, 2] (m) at centroid height offset.

    offset (m, signed), ea (N), ei, gj (N m^2), m (kg/m), i_phi (kg m): arrays [E] (or scalars).
    """
    xy = np.asarray(xy, dtype=float)
    ne = xy.shape[0]
    length = np.linalg.norm(xy[:, 1] - xy[:, 0], axis=1)
    if np.any(length <= 0.0):
        raise InputError("structure.beam_elements", "zero length")
    e, ea, ei, gj, m, i_phi = (np.broadcast_to(np.asarray(v, dtype=float), (ne,)) for v in
                               (offset, ea, ei, gj, m, i_phi))
    r = _local_rows(length, e)
    wl = _GW[None, :] * length[:, None]
    dphi = np.zeros(12)
    dphi[2], dphi[8] = -1.0, 1.0
    k = (_gram(wl, ea, r["eps"], r["eps"]) + _gram(wl, ei, r["wpp"], r["wpp"])
         + (gj / length)[:, None, None] * np.outer(dphi, dphi))
    mm = (_gram(wl, m, r["w"], r["w"]) + _gram(wl, m, r["uc"], r["uc"]) + _gram(wl, m, r["vc"], r["vc"])
          + _gram(wl, i_phi, r["phi"], r["phi"]))
    return _to_global(xy, k), _to_global(xy, mm)
