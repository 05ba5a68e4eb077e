"""Element groups of a plate wing's FE model: DOF connectivity, the stiffening beam and the lumped mass.

Two DOF layouts share one node numbering: the plate-bending layout (3 DOFs per node: w, w_x,
w_y) and the flat-shell layout (6 per node: w, w_x, w_y, u, v, theta_z), so w is DOF
``stride * node`` in both. Each group is a (connectivity [E, n], element matrices [E, n, n]) pair.
"""

from __future__ import annotations

import numpy as np

from romams_core.structure.beam import beam_element_matrices, rectangle_torsion_constant
from romams_core.structure.plate_mesh import PlateMesh
from romams_core.structure.stiffener import offset_beam_matrices
from romams_core.wing import StiffeningBeam

Part = tuple[np.ndarray, np.ndarray]


def node_dofs(nodes: np.ndarray, stride: int = 3, first: int = 0, count: int = 3) -> np.ndarray:
    """DOF connectivity [E, count n] of node lists [E, n]: DOFs first .. first + count - 1 of each node."""
    return (stride * nodes[:, :, None] + first + np.arange(count)).reshape(nodes.shape[0], -1)


def beam_offset(beam: StiffeningBeam, plate_t: np.ndarray) -> np.ndarray:
    """Signed height (m) of the beam centroid above the mid-plane: 0 on the mid-plane, -(t + height) / 2 eccentric.

    The eccentric beam is glued to the lower face (z < 0); the side does not change a flat plate's frequencies
    or w mode shapes (mirror symmetry), only the sign of the in-plane motion.
    """
    if beam.placement == "mid-plane":
        return np.zeros_like(plate_t)
    return -0.5 * (plate_t + beam.height)


def beam_parts(pm: PlateMesh, beam: StiffeningBeam, plate_t: np.ndarray, stride: int) -> tuple[Part, Part, float]:
    """Beam stiffness and mass groups and the beam mass (kg); plate_t: plate thickness (m) at each beam element.

    stride 3: mid-plane beam on the bending DOFs; stride 6: the offset beam on the shell DOFs (any placement).
    """
    bn = pm.beam_nodes()
    bnodes = np.column_stack([bn[:-1], bn[1:]])
    bxy = pm.xy[bnodes]
    bh, bw = beam.height, beam.width
    a = bh * bw
    mat = beam.material
    ei = mat.E1 * bw * bh**3 / 12.0
    gj = mat.G12 * rectangle_torsion_constant(bh, bw)
    m = mat.density * a
    i_phi = m * (bh**2 + bw**2) / 12.0
    if stride == 3:
        kb, mb = beam_element_matrices(bxy, ei, gj, m, 0.0, i_phi)
        conn = node_dofs(bnodes)
    else:
        kb, mb = offset_beam_matrices(bxy, beam_offset(beam, plate_t), mat.E1 * a, ei, gj, m, i_phi)
        conn = node_dofs(bnodes, stride, 0, stride)
    mass = float(m * np.sum(np.linalg.norm(bxy[:, 1] - bxy[:, 0], axis=1)))
    return (conn, kb), (conn, mb), mass


def lumped_mass_part(pm: PlateMesh, mass: float, span_fraction: float, stride: int) -> Part:
    """Mass group of a point mass (kg) on the leading edge at span_fraction (no rotary inertia).

    w: the edge's cubic Hermite interpolation of w and t.grad w; u, v (shell layout): linear along the edge.
    """
    pos = span_fraction * pm.n_span
    j0 = int(min(np.floor(pos), pm.n_span - 1))
    u = pos - j0
    na, nb = int(pm.node(0, j0)), int(pm.node(0, j0 + 1))
    dvec = pm.xy[nb] - pm.xy[na]
    length = float(np.linalg.norm(dvec))
    tvec = dvec / length
    hv = np.array([1 - 3 * u**2 + 2 * u**3, length * (u - 2 * u**2 + u**3), 3 * u**2 - 2 * u**3,
                   length * (-(u**2) + u**3)])
    rows = np.zeros((3, 2 * stride))  # w, u, v of the point on nodes a, b
    rows[0, [0, 1, 2]] = hv[0], hv[1] * tvec[0], hv[1] * tvec[1]
    rows[0, [stride, stride + 1, stride + 2]] = hv[2], hv[3] * tvec[0], hv[3] * tvec[1]
    gram = np.outer(rows[0], rows[0])
    if stride > 3:
        rows[1, [3, stride + 3]] = 1.0 - u, u
        rows[2, [4, stride + 4]] = 1.0 - u, u
        gram = gram + np.outer(rows[1], rows[1]) + np.outer(rows[2], rows[2])
    idx = np.r_[stride * na : stride * na + stride, stride * nb : stride * nb + stride]
    return idx[None], (mass * gram)[None]
