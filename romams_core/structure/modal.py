"""Modal analysis of a wing definition: FE assembly, clamped-root eigenproblem, mapping to the standard mesh.

Plate wings: DKT plate + mid-plane stiffening beam + leading-edge point mass (``PlateStructure``).
Beam wings: Euler-Bernoulli bending-torsion beam on the elastic axis with rigid chordwise sections
(``BeamStructure``), w(x, y) = h(y) - (x - x_ea) alpha(y).

Modes are mass-normalized (phi^T M phi = 1), frequencies in Hz and rad/s, and each mode's sign is
fixed so that its largest |w| on the standard mesh is positive.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.interpolate import PchipInterpolator
from scipy.linalg import cho_solve_banded, cholesky_banded, eigh
from scipy.sparse.linalg import LinearOperator, eigsh

from romams_core.errors import InputError
from romams_core.mesh import Planform, StandardMesh, standard_mesh
from romams_core.structure.beam import beam_element_matrices, rectangle_torsion_constant
from romams_core.structure.dkt import (
    bernstein_coefficients,
    bernstein_values,
    cubic_mass,
    dkt_stiffness,
    triangle_geometry,
)
from romams_core.structure.plate_mesh import PlateMesh, locate, plate_mesh
from romams_core.wing import BeamStructure, PlateStructure, WingDefinition


@dataclass
class ModalResult:
    """Modes of one structure: frequencies (Hz, rad/s), mass-normalized w on the standard mesh [N, k] (m/sqrt(kg))."""

    frequencies_hz: np.ndarray  # [k]
    omega: np.ndarray  # [k] rad/s
    shapes: np.ndarray  # [N, k] out-of-plane displacement on the standard mesh, mass-normalized
    mass_kg: float  # total structural mass, kg
    n_fe_nodes: int
    fe_xy: np.ndarray  # [P, 2] FE node coordinates, m
    fe_shapes: np.ndarray  # [P, k] w at the FE nodes
    fe_triangles: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), dtype=int))  # [E, 3] (plates)

    @property
    def n_modes(self) -> int:
        """Number of modes k."""
        return int(self.frequencies_hz.size)


@dataclass
class FEModel:
    """Assembled FE model: sparse K (N/m ...) and M (kg ...) on 3 DOFs per node, with bookkeeping."""

    K: sp.csc_matrix
    M: sp.csc_matrix
    free: np.ndarray  # [n_free] DOF indices not clamped
    xy: np.ndarray  # [P, 2] node coordinates, m
    mass_kg: float
    interp: sp.csr_matrix  # [N_std, 3 P] map from DOFs to w on the standard mesh
    triangles: np.ndarray  # [E, 3] (empty for beams)


def _assemble(conn: np.ndarray, ke: np.ndarray, n_dof: int) -> sp.csc_matrix:
    """Sparse global matrix from element matrices ke [E, n, n] with DOF connectivity conn [E, n]."""
    return _assemble_many([(conn, ke)], n_dof)


def _assemble_many(parts: list[tuple[np.ndarray, np.ndarray]], n_dof: int) -> sp.csc_matrix:
    """One sparse matrix from several (connectivity [E, n], element matrices [E, n, n]) groups."""
    rows = np.concatenate([np.repeat(c, c.shape[1], axis=1).ravel() for c, _ in parts])
    cols = np.concatenate([np.tile(c, (1, c.shape[1])).ravel() for c, _ in parts])
    vals = np.concatenate([k.ravel() for _, k in parts])
    return sp.csc_matrix((vals, (rows, cols)), shape=(n_dof, n_dof))


def _dofs(nodes: np.ndarray) -> np.ndarray:
    """DOF connectivity [E, 3 n] of element node lists [E, n] (3 DOFs per node)."""
    return (3 * nodes[:, :, None] + np.arange(3)).reshape(nodes.shape[0], -1)


def naca4_thickness_form(xi: np.ndarray) -> np.ndarray:
    """Symmetric NACA 4-digit thickness distribution at chord fractions xi, normalized to a maximum of 1."""
    xi = np.clip(np.asarray(xi, dtype=float), 0.0, 1.0)
    poly = 0.2969 * np.sqrt(xi) - 0.1260 * xi - 0.3516 * xi**2 + 0.2843 * xi**3 - 0.1015 * xi**4
    return poly / 0.10002879  # maximum of the polynomial (at xi = 0.29983)


# NACA 65A004 half thickness (fraction of chord) at chord fractions (reference/agard445.md)
_NACA65A004_X = np.array([0, 0.5, 0.75, 1.25, 2.5, 5, 7.5, 10, 15, 20, 25, 30, 35, 40, 45, 50, 55, 60, 65, 70, 75, 80,
                          85, 90, 95, 100]) / 100.0
_NACA65A004_Z = np.array([0, 0.304, 0.368, 0.469, 0.647, 0.875, 1.059, 1.213, 1.459, 1.645, 1.789, 1.892, 1.962,
                          1.997, 1.996, 1.954, 1.868, 1.743, 1.586, 1.402, 1.195, 0.967, 0.729, 0.49, 0.25, 0]) / 100.0
_NACA65A004 = PchipInterpolator(_NACA65A004_X, _NACA65A004_Z / _NACA65A004_Z.max())

# NACA 64A010 half thickness (fraction of chord) at chord fractions: the ordinates tabulated in NACA Report 903
# (Loftin, "Theoretical and experimental data for a number of NACA 6A-series airfoil sections", 1948); the
# trailing edge is open (0.021 % of the chord per side). The AGARD CT6 pitching-airfoil section (tsd validation).
_NACA64A010_X = np.array([0, 0.5, 0.75, 1.25, 2.5, 5, 7.5, 10, 15, 20, 25, 30, 35, 40, 45, 50, 55, 60, 65, 70, 75, 80,
                          85, 90, 95, 100]) / 100.0
_NACA64A010_Z = np.array([0, 0.804, 0.969, 1.225, 1.688, 2.327, 2.805, 3.199, 3.813, 4.272, 4.606, 4.837, 4.968,
                          4.995, 4.894, 4.684, 4.388, 4.021, 3.597, 3.127, 2.623, 2.103, 1.582, 1.062, 0.541,
                          0.021]) / 100.0
_NACA64A010 = PchipInterpolator(_NACA64A010_X, _NACA64A010_Z / _NACA64A010_Z.max())


def thickness_form(name: str, xi: np.ndarray) -> np.ndarray:
    """Airfoil thickness form (maximum 1) named ``name`` ("naca4", "naca65a004" or "naca64a010") at chord fractions
    xi."""
    if name == "naca4":
        return naca4_thickness_form(xi)
    if name in ("naca65a004", "naca64a010"):
        table = _NACA65A004 if name == "naca65a004" else _NACA64A010
        return np.asarray(table(np.clip(np.asarray(xi, dtype=float), 0.0, 1.0)), dtype=float)
    raise InputError("structure.thickness_form", f"no airfoil form {name!r}")


def plate_thickness(planform: Planform, s: PlateStructure, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Plate thickness (m) at points x, y (m)."""
    if s.thickness_form == "constant":
        t = np.full(np.shape(x), s.thickness)
    else:
        xi, _ = planform.to_xi_eta(x, y)
        tmax = s.thickness_to_chord * planform.chord(y)
        t = tmax * np.maximum(thickness_form(s.thickness_form, xi), s.min_thickness_fraction)
    return t * s.thickness_ratio


def plate_model(planform: Planform, s: PlateStructure, mesh: StandardMesh | None = None) -> FEModel:
    """Assemble the plate (+ beam + lumped mass) FE model with a clamped root."""
    beam = s.beam
    pm = plate_mesh(planform, s.fe_n_chord, s.fe_n_span, None if beam is None else (beam.root_position,
                                                                                    beam.tip_position))
    n_dof = 3 * pm.n_nodes
    tri = pm.triangles
    exy = pm.xy[tri]  # [E, 3, 2]
    cen = exy.mean(axis=1)
    h = plate_thickness(planform, s, cen[:, 0], cen[:, 1])
    q = s.material.plane_stress_q()
    d = (h**3 / 12.0)[:, None, None] * q[None]
    ke = dkt_stiffness(exy, d)
    me = cubic_mass(exy, s.material.density * h)
    conn = _dofs(tri)
    k_parts, m_parts = [(conn, ke)], [(conn, me)]
    area, _, _ = triangle_geometry(exy)
    mass = float(np.sum(s.material.density * h * area))
    if beam is not None:
        bn = pm.beam_nodes()
        bnodes = np.column_stack([bn[:-1], bn[1:]])
        bh, bw = beam.height, beam.width
        a = bh * bw
        ei = beam.material.E1 * bw * bh**3 / 12.0
        gj = beam.material.G12 * rectangle_torsion_constant(bh, bw)
        rho = beam.material.density
        kb, mb = beam_element_matrices(pm.xy[bnodes], ei, gj, rho * a, 0.0, rho * a * (bh**2 + bw**2) / 12.0)
        bconn = _dofs(bnodes)
        k_parts.append((bconn, kb))
        m_parts.append((bconn, mb))
        mass += float(rho * a * np.sum(np.linalg.norm(pm.xy[bn[1:]] - pm.xy[bn[:-1]], axis=1)))
    if s.lumped_mass is not None and s.lumped_mass.mass > 0.0:
        lm = s.lumped_mass
        pos = lm.span_fraction * pm.n_span
        j0 = int(min(np.floor(pos), pm.n_span - 1))
        u = pos - j0
        na, nb = pm.node(0, j0), pm.node(0, j0 + 1)
        dvec = pm.xy[nb] - pm.xy[na]
        length = float(np.linalg.norm(dvec))
        tvec = dvec / length
        hv = np.array([1 - 3 * u**2 + 2 * u**3, length * (u - 2 * u**2 + u**3), 3 * u**2 - 2 * u**3,
                       length * (-(u**2) + u**3)])
        nvec = np.array([hv[0], hv[1] * tvec[0], hv[1] * tvec[1], hv[2], hv[3] * tvec[0], hv[3] * tvec[1]])
        idx = np.r_[3 * na : 3 * na + 3, 3 * nb : 3 * nb + 3]
        m_parts.append((idx[None], (lm.mass * np.outer(nvec, nvec))[None]))
        mass += float(lm.mass)
    root = pm.node(np.arange(pm.n_chord + 1), 0)
    clamped = np.zeros(n_dof, dtype=bool)
    clamped[_dofs(root[None]).ravel()] = True
    mesh = mesh if mesh is not None else standard_mesh(planform)
    K, M = _assemble_many(k_parts, n_dof), _assemble_many(m_parts, n_dof)
    return FEModel(K=K, M=M, free=np.flatnonzero(~clamped), xy=pm.xy, mass_kg=mass,
                   interp=plate_interpolation(pm, planform, mesh.x, mesh.y), triangles=tri)


def plate_interpolation(pm: PlateMesh, planform: Planform, x: np.ndarray, y: np.ndarray) -> sp.csr_matrix:
    """Sparse [P_target, 3 P] map from plate DOFs to w at points (m), by the elements' cubic interpolation."""
    t, lam = locate(pm, x, y, planform.semispan)
    tri = pm.triangles[t]
    c = bernstein_coefficients(pm.xy[tri])  # [P, 10, 9]
    vals = np.einsum("pa,pai->pi", bernstein_values(lam), c)
    rows = np.repeat(np.arange(t.size), 9)
    return sp.csr_matrix((vals.ravel(), (rows, _dofs(tri).ravel())), shape=(t.size, 3 * pm.n_nodes))


def beam_model(planform: Planform, s: BeamStructure, mesh: StandardMesh | None = None) -> FEModel:
    """Assemble the elastic-axis beam FE model (bending, torsion, CG-offset coupling) with a clamped root."""
    ne = s.n_elements
    eta = np.linspace(0.0, 1.0, ne + 1)
    x, y = planform.to_xy(np.full(ne + 1, s.ea_chord_fraction), eta)
    xy = np.column_stack([x, y])
    nodes = np.column_stack([np.arange(ne), np.arange(1, ne + 1)])
    exy = xy[nodes]
    ymid = exy[:, :, 1].mean(axis=1)
    chord = planform.chord(ymid)
    d = exy[:, 1] - exy[:, 0]
    tvec = d / np.linalg.norm(d, axis=1)[:, None]
    offset = (s.cg_chord_fraction - s.ea_chord_fraction) * chord * tvec[:, 1]  # streamwise offset projected on n
    m = s.mass_per_length
    kb, mb = beam_element_matrices(exy, s.EI, s.GJ, m, m * offset, s.inertia_ea_per_length)
    n_dof = 3 * (ne + 1)
    conn = _dofs(nodes)
    K = _assemble(conn, kb, n_dof)
    M = _assemble(conn, mb, n_dof)
    free = np.arange(3, n_dof)
    mesh = mesh if mesh is not None else standard_mesh(planform)
    # standard mesh: w = Hermite(w, grad w . t) along the axis + (x - x_ea(y)) * linear(w_x)
    eta_p = np.clip(mesh.y / planform.semispan, 0.0, 1.0)
    e = np.minimum((eta_p * ne).astype(int), ne - 1)
    u = eta_p * ne - e
    length = np.linalg.norm(d, axis=1)[e]
    tv = tvec[e]
    h = np.column_stack([1 - 3 * u**2 + 2 * u**3, length * (u - 2 * u**2 + u**3), 3 * u**2 - 2 * u**3,
                         length * (-(u**2) + u**3)])
    x_ea = planform.to_xy(np.full_like(eta_p, s.ea_chord_fraction), eta_p)[0]
    dx = mesh.x - x_ea
    vals = np.column_stack([
        h[:, 0], h[:, 1] * tv[:, 0] + (1 - u) * dx, h[:, 1] * tv[:, 1],
        h[:, 2], h[:, 3] * tv[:, 0] + u * dx, h[:, 3] * tv[:, 1],
    ])
    rows = np.repeat(np.arange(mesh.n_nodes), 6)
    interp = sp.csr_matrix((vals.ravel(), (rows, conn[e].ravel())), shape=(mesh.n_nodes, n_dof))
    mass = float(m * np.sum(np.linalg.norm(d, axis=1)))
    return FEModel(K=K, M=M, free=free, xy=xy, mass_kg=mass, interp=interp, triangles=np.zeros((0, 3), dtype=int))


def build_model(
    wing: WingDefinition,
    design: Mapping[str, float] | Sequence[float] | np.ndarray | None = None,
    mesh: StandardMesh | None = None,
) -> FEModel:
    """FE model of a wing's structure for a design (None: the baseline)."""
    s = wing.structure_for(design)
    if isinstance(s, BeamStructure):
        return beam_model(wing.planform, s, mesh)
    return plate_model(wing.planform, s, mesh)


def _stiffness_inverse(k: sp.spmatrix) -> LinearOperator | None:
    """K^-1 as an operator via banded Cholesky (the structured node order keeps K narrow); None if not banded."""
    c = k.tocoo()
    c.sum_duplicates()
    upper = c.col >= c.row
    r, col, v = c.row[upper], c.col[upper], c.data[upper]
    n = k.shape[0]
    u = int((col - r).max(initial=0))
    if u > n // 4:
        return None
    ab = np.zeros((u + 1, n))
    ab[u + r - col, col] = v
    try:
        cb = cholesky_banded(ab, lower=False, check_finite=False)
    except np.linalg.LinAlgError:
        return None  # not positive definite: let eigsh factor K - sigma M itself
    return LinearOperator((n, n), matvec=lambda x: cho_solve_banded((cb, False), x, check_finite=False), dtype=float)


def solve_modes(model: FEModel, n_modes: int) -> tuple[np.ndarray, np.ndarray]:
    """Lowest eigenpairs: omega [k] (rad/s) and mass-normalized full-DOF modes [3P, k] (clamped DOFs zero)."""
    f = model.free
    kff = model.K[f][:, f]
    mff = model.M[f][:, f]
    if not 1 <= n_modes < f.size:
        raise InputError("n_modes", f"must be in [1, {f.size - 1}], got {n_modes}")
    if f.size <= 60:
        lam, vec = eigh(kff.toarray(), mff.toarray(), subset_by_index=(0, n_modes - 1))
    else:
        # a fixed start vector: ARPACK's default is random, which makes repeated analyses of one structure differ
        # at round-off (the baseline compared with itself must give a zero envelope margin, everywhere)
        v0 = np.random.default_rng(0).standard_normal(f.size)
        lam, vec = eigsh(kff, k=n_modes, M=mff, sigma=0.0, which="LM", OPinv=_stiffness_inverse(kff), v0=v0)
    order = np.argsort(lam)
    lam, vec = lam[order], vec[:, order]
    gm = np.einsum("ik,ik->k", vec, mff @ vec)
    vec = vec / np.sqrt(gm)[None, :]
    phi = np.zeros((model.K.shape[0], n_modes))
    phi[f] = vec
    return np.sqrt(np.maximum(lam, 0.0)), phi


def modal_analysis(
    wing: WingDefinition,
    design: Mapping[str, float] | Sequence[float] | np.ndarray | None = None,
    n_modes: int = 4,
    mesh: StandardMesh | None = None,
) -> ModalResult:
    """Lowest n_modes modes of a wing design (None: baseline), mapped to the standard mesh (default: the wing's)."""
    if isinstance(n_modes, bool) or not isinstance(n_modes, int | np.integer) or n_modes < 1:
        raise InputError("n_modes", f"must be a positive integer, got {n_modes!r}")
    mesh = mesh if mesh is not None else standard_mesh(wing.planform)
    model = build_model(wing, design, mesh)
    omega, phi = solve_modes(model, int(n_modes))
    shapes = model.interp @ phi
    imax = np.argmax(np.abs(shapes), axis=0)
    sign = np.where(shapes[imax, np.arange(shapes.shape[1])] < 0.0, -1.0, 1.0)
    shapes = shapes * sign
    fe_w = phi[0::3] * sign
    return ModalResult(
        frequencies_hz=omega / (2.0 * np.pi),
        omega=omega,
        shapes=shapes,
        mass_kg=model.mass_kg,
        n_fe_nodes=int(model.xy.shape[0]),
        fe_xy=model.xy,
        fe_shapes=fe_w,
        fe_triangles=model.triangles,
    )
