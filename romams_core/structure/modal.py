"""Modal analysis of a wing definition: FE assembly, clamped-root eigenproblem, mapping to the standard mesh.

Plate wings: DKT plate + stiffening beam + leading-edge point mass (``PlateStructure``). With the beam on the
mid-plane the plate has bending DOFs only (w, w_x, w_y per node); with an eccentric beam it is a flat shell
(+ Allman membrane u, v, theta_z per node) and the beam is linked to the plate at its centroid's offset.
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
from romams_core.structure.beam import beam_element_matrices
from romams_core.structure.dkt import (
    bernstein_coefficients,
    bernstein_values,
    cubic_mass,
    dkt_stiffness,
    triangle_geometry,
)
from romams_core.structure.membrane import membrane_mass, membrane_stiffness
from romams_core.structure.plate_cache import topology
from romams_core.structure.plate_mesh import PlateMesh, locate, plate_mesh
from romams_core.structure.plate_parts import beam_parts, lumped_mass_part, node_dofs
from romams_core.structure.sparse_pattern import FreePart
from romams_core.structure.stiffener import SHELL_DOFS
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
    """Assembled FE model: sparse K (N/m ...) and M (kg ...), with bookkeeping.

    ``dofs_per_node``: 3 (w, w_x, w_y) or 6 (flat shell: w, w_x, w_y, u, v, theta_z); w of node p is DOF
    ``dofs_per_node * p`` either way.
    """

    K: sp.csc_matrix
    M: sp.csc_matrix
    free: np.ndarray  # [n_free] DOF indices not clamped
    xy: np.ndarray  # [P, 2] node coordinates, m
    mass_kg: float
    interp: sp.csr_matrix  # [N_std, dofs_per_node P] map from DOFs to w on the standard mesh
    triangles: np.ndarray  # [E, 3] (empty for beams)
    dofs_per_node: int = 3
    free_part: FreePart | None = None  # K and M's free-free layout (plate models; used while ``free`` is its own)


def _assemble(conn: np.ndarray, ke: np.ndarray, n_dof: int) -> sp.csc_matrix:
    """Sparse global matrix from element matrices ke [E, n, n] with DOF connectivity conn [E, n]."""
    return _assemble_many([(conn, ke)], n_dof)


def _assemble_many(parts: list[tuple[np.ndarray, np.ndarray]], n_dof: int) -> sp.csc_matrix:
    """One sparse matrix from several (connectivity [E, n], element matrices [E, n, n]) groups."""
    rows = np.concatenate([np.repeat(c, c.shape[1], axis=1).ravel() for c, _ in parts])
    cols = np.concatenate([np.tile(c, (1, c.shape[1])).ravel() for c, _ in parts])
    vals = np.concatenate([k.ravel() for _, k in parts])
    return sp.csc_matrix((vals, (rows, cols)), shape=(n_dof, n_dof))


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


def plate_model(planform: Planform, s: PlateStructure, mesh: StandardMesh | None = None,
                membrane: bool | None = None) -> FEModel:
    """Assemble the plate (+ beam + lumped mass) FE model with a clamped root.

    membrane: give the plate membrane DOFs (flat shell); None: exactly when the beam is eccentric. K and M are
    summed into the sparse pattern ``plate_cache`` keeps per mesh topology.
    """
    beam = s.beam
    if membrane is None:
        membrane = beam is not None and beam.placement == "eccentric"
    if not membrane and beam is not None and beam.placement == "eccentric":
        raise InputError("structure.beam.placement", "an eccentric beam needs the plate's membrane DOFs")
    stride = SHELL_DOFS if membrane else 3
    pm, k_parts, m_parts, mass = plate_groups(planform, s, stride)
    n_dof = stride * pm.n_nodes
    root = pm.node(np.arange(pm.n_chord + 1), 0)
    clamped = np.zeros(n_dof, dtype=bool)
    clamped[node_dofs(root[None], stride, 0, stride).ravel()] = True
    free = np.flatnonzero(~clamped)
    mesh = mesh if mesh is not None else standard_mesh(planform)
    K, M, free_part = _assemble_pair(k_parts, m_parts, n_dof, free)
    return FEModel(K=K, M=M, free=free, xy=pm.xy, mass_kg=mass,
                   interp=plate_interpolation(pm, planform, mesh.x, mesh.y, stride), triangles=pm.triangles,
                   dofs_per_node=stride, free_part=free_part)


def plate_groups(planform: Planform, s: PlateStructure, stride: int
                 ) -> tuple[PlateMesh, list[tuple[np.ndarray, np.ndarray]], list[tuple[np.ndarray, np.ndarray]], float]:
    """(FE mesh, stiffness groups, mass groups, structural mass kg) of a plate structure with ``stride`` DOFs per
    node (3 bending, 6 flat shell); groups are (connectivity [E, n], element matrices [E, n, n]), the mass groups
    starting with the stiffness groups' connectivities (the same arrays) and ending with the lumped mass."""
    beam = s.beam
    pm = plate_mesh(planform, s.fe_n_chord, s.fe_n_span, None if beam is None else (beam.root_position,
                                                                                    beam.tip_position))
    tri = pm.triangles
    exy = pm.xy[tri]  # [E, 3, 2]
    cen = exy.mean(axis=1)
    h = plate_thickness(planform, s, cen[:, 0], cen[:, 1])
    q = s.material.plane_stress_q()
    rho_h = s.material.density * h
    conn = node_dofs(tri, stride)
    k_parts = [(conn, dkt_stiffness(exy, (h**3 / 12.0)[:, None, None] * q[None]))]
    m_parts = [(conn, cubic_mass(exy, rho_h))]
    if stride != 3:
        mconn = node_dofs(tri, stride, 3)
        k_parts.append((mconn, membrane_stiffness(exy, h[:, None, None] * q[None])))
        m_parts.append((mconn, membrane_mass(exy, rho_h)))
    area, _, _ = triangle_geometry(exy)
    mass = float(np.sum(rho_h * area))
    if beam is not None:
        bn = pm.beam_nodes()
        mid = 0.5 * (pm.xy[bn[:-1]] + pm.xy[bn[1:]])
        kb, mb, beam_mass = beam_parts(pm, beam, plate_thickness(planform, s, mid[:, 0], mid[:, 1]), stride)
        k_parts.append(kb)
        m_parts.append(mb)
        mass += beam_mass
    if s.lumped_mass is not None and s.lumped_mass.mass > 0.0:
        m_parts.append(lumped_mass_part(pm, s.lumped_mass.mass, s.lumped_mass.span_fraction, stride))
        mass += float(s.lumped_mass.mass)
    return pm, k_parts, m_parts, mass


def _assemble_pair(k_parts: list[tuple[np.ndarray, np.ndarray]], m_parts: list[tuple[np.ndarray, np.ndarray]],
                   n_dof: int, free: np.ndarray) -> tuple[sp.csc_matrix, sp.csc_matrix, FreePart | None]:
    """(K, M, their free-free layout) on the cached pattern of the stiffness groups (``plate_cache``); a further
    mass group (the lumped mass) adds its nonzero entries, and one outside the pattern (on a DOF pair no element
    joins) gives both matrices by the general assembly."""
    top = topology([c for c, _ in k_parts], n_dof, free)
    pat = top.pattern
    extra = [pat.place(c, v) for c, v in m_parts[len(k_parts):]]
    same = len(m_parts) >= len(k_parts) and all(
        mc is kc for (mc, _), (kc, _) in zip(m_parts[:len(k_parts)], k_parts, strict=True))
    placed = [e for e in extra if e is not None]
    if not same or len(placed) < len(extra):
        return _assemble_many(k_parts, n_dof), _assemble_many(m_parts, n_dof), None
    K = pat.matrix(list(top.positions), [v for _, v in k_parts])
    M = pat.matrix(list(top.positions) + [p for p, _ in placed],
                   [v for _, v in m_parts[:len(k_parts)]] + [v for _, v in placed])
    return K, M, top.free_part


def plate_interpolation(pm: PlateMesh, planform: Planform, x: np.ndarray, y: np.ndarray,
                        stride: int = 3) -> sp.csr_matrix:
    """Sparse [P_target, stride P] map from plate DOFs (stride per node) to w at points (m), by the elements' cubic
    interpolation."""
    t, lam = locate(pm, x, y, planform.semispan)
    tri = pm.triangles[t]
    c = bernstein_coefficients(pm.xy[tri])  # [P, 10, 9]
    vals = np.einsum("pa,pai->pi", bernstein_values(lam), c)
    rows = np.repeat(np.arange(t.size), 9)
    return sp.csr_matrix((vals.ravel(), (rows, node_dofs(tri, stride).ravel())), shape=(t.size, stride * pm.n_nodes))


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
    conn = node_dofs(nodes)
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
    if _too_wide(u, n):  # before the band array is allocated
        return None
    ab = np.zeros((u + 1, n))
    ab[u + r - col, col] = v
    return _banded_inverse(ab)


def _too_wide(u: int, n: int) -> bool:
    """A band of upper width u on n DOFs is too wide for the banded Cholesky to pay."""
    return u > n // 4


def _banded_inverse(ab: np.ndarray) -> LinearOperator | None:
    """K^-1 as an operator from K's upper band ab [u + 1, n] (banded Cholesky); None if K is not positive
    definite or its band is too wide to pay (eigsh then factors K - sigma M itself)."""
    n = ab.shape[1]
    if _too_wide(ab.shape[0] - 1, n):
        return None
    try:
        cb = cholesky_banded(ab, lower=False, check_finite=False)
    except np.linalg.LinAlgError:
        return None
    return LinearOperator((n, n), matvec=lambda x: cho_solve_banded((cb, False), x, check_finite=False), dtype=float)


def solve_modes(model: FEModel, n_modes: int) -> tuple[np.ndarray, np.ndarray]:
    """Lowest eigenpairs: omega [k] (rad/s) and mass-normalized full-DOF modes [n_dof, k] (clamped DOFs zero)."""
    f = model.free
    fp = model.free_part
    if fp is not None and not np.array_equal(fp.free, f):
        fp = None  # ``free`` changed after the assembly (a study releasing DOFs): the general slicing
    kff = model.K[f][:, f] if fp is None else fp.block(model.K)
    mff = model.M[f][:, f] if fp is None else fp.block(model.M)
    if not 1 <= n_modes < f.size:
        raise InputError("n_modes", f"must be in [1, {f.size - 1}], got {n_modes}")
    if f.size <= 60:
        lam, vec = eigh(kff.toarray(), mff.toarray(), subset_by_index=(0, n_modes - 1))
    else:
        # a fixed start vector: ARPACK's default is random, which makes repeated analyses of one structure differ
        # at round-off (the baseline compared with itself must give a zero envelope margin, everywhere)
        v0 = np.random.default_rng(0).standard_normal(f.size)
        op = _stiffness_inverse(kff) if fp is None else _banded_inverse(fp.banded_upper(kff))
        lam, vec = eigsh(kff, k=n_modes, M=mff, sigma=0.0, which="LM", OPinv=op, v0=v0)
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
    fe_w = phi[0 :: model.dofs_per_node] * sign
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
