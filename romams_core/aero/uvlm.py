"""Linear unsteady vortex-lattice method (UVLM) on the standard mesh, frozen flat wake.

Model (derivation and verification in docs/aerodynamics.md):
- vortex rings on the standard-mesh panels, shifted a quarter panel chord aft (Kutta condition implicit);
  optional tip inset of the outer side legs by a quarter strip (Hough); the mesh is a half wing whose root
  condition (``symmetry``, the DLM's) sets the image lattice mirrored about y = 0, bound rings and wake alike:
  the same strengths (symmetric), the opposite (antisymmetric), or none (a free wing, whose root edge is then
  a tip: inset too);
- collocation at 3/4 panel chord, mid lattice strip, normal +z; transpiration boundary condition
  w = dh/dt + V dh/dx with h and dh/dx from the panel's bilinear interpolant of the nodal shape values;
- flat wake convected at V, one row (length dt_star * c_ref) shed per step, truncated after
  ``wake_chords`` chords (last row dropped);
- linearized pressure: panel force rho dy (V dG_x + dx dG/dt) (Kutta-Joukowski on the bound leg plus the
  unsteady term, dG/dt by BDF2), generalized forces at the 1/4-chord force points;
- compressibility by the Prandtl-Glauert/Goethert stretch x -> x / beta, beta = sqrt(1 - M^2), of the
  lattice and wake for the influence coefficients, with physical normal-wash and pressure. This is
  exact as k -> 0 only, neglects acoustic retardation, and fails as M -> 1 (beta -> 0): results above
  M = 0.9 carry a warning.

Everything is nondimensional (lengths / c_ref, time t* = t V / c_ref, G / (V c_ref), velocities / V), so
one march serves every V and rho. All arrays that are per-panel use the panel index p = j * n_chord + i
(i chordwise, j spanwise) of ``StandardMesh.panels``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from numpy.lib.stride_tricks import sliding_window_view

from romams_core.aero.protocol import (
    Cancelled,
    ProgressFn,
    SolverInfo,
    check_dt_star,
    check_mach,
    check_shapes,
    check_signals,
    image_sign,
    mach_warnings,
)
from romams_core.errors import InputError
from romams_core.mesh import StandardMesh, refined_mesh
from romams_core.statespace import DiscreteSS

__all__ = [
    "UvlmSystem",
    "UvlmSolver",
    "build_uvlm",
    "march",
    "frequency_response",
    "panel_forces_frequency",
    "uvlm_state_space",
    "refine_mesh",
    "Cancelled",
]

_FOUR_PI = 4.0 * math.pi


def _segment_wz(
    px: np.ndarray, py: np.ndarray, ax: np.ndarray, ay: np.ndarray, bx: np.ndarray, by: np.ndarray, cutoff: float
) -> np.ndarray:
    """z-velocity [P, S] induced at in-plane points by unit straight vortex segments A->B in the plane z = 0."""
    r1x = px[:, None] - ax[None, :]
    r1y = py[:, None] - ay[None, :]
    r2x = px[:, None] - bx[None, :]
    r2y = py[:, None] - by[None, :]
    cz = r1x * r2y - r1y * r2x
    n1 = np.hypot(r1x, r1y)
    n2 = np.hypot(r2x, r2y)
    r0x = (bx - ax)[None, :]
    r0y = (by - ay)[None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        dot = r0x * (r1x / n1 - r2x / n2) + r0y * (r1y / n1 - r2y / n2)
        v = dot / (_FOUR_PI * cz)
    bad = (np.abs(cz) <= cutoff * np.hypot(r0x, r0y)) | (n1 < cutoff) | (n2 < cutoff)
    v[bad] = 0.0
    return v


def _ring_influence(
    px: np.ndarray,
    py: np.ndarray,
    xc: np.ndarray,
    yc: np.ndarray,
    cutoff: float = 1e-9,
    chunk: int = 2_000_000,
    image_sign: float = 1.0,
) -> np.ndarray:
    """z-velocity [P, nL, ns] (per unit ring strength, lengths / c_ref) at points from unit vortex rings on a
    corner grid xc [nL+1, ns+1], yc [ns+1].

    Ring (a, b) has corners (a, b), (a, b+1), (a+1, b+1), (a+1, b); positive strength induces downwash
    inside (lift up for flow along +x). The mirror image about y = 0 is added with strength ``image_sign``
    times the ring's (+1 symmetric, -1 antisymmetric loading; 0: no image, not evaluated).
    Unique legs are evaluated once and differenced, chunked over points to bound memory.
    """
    nl1, ns1 = xc.shape
    nl, ns = nl1 - 1, ns1 - 1
    yy = np.broadcast_to(yc[None, :], xc.shape)
    # spanwise legs (a, b) -> (a, b+1), and chordwise legs (a, b) -> (a+1, b)
    s_ax, s_ay = xc[:, :-1].ravel(), yy[:, :-1].ravel()
    s_bx, s_by = xc[:, 1:].ravel(), yy[:, 1:].ravel()
    c_ax, c_ay = xc[:-1, :].ravel(), yy[:-1, :].ravel()
    c_bx, c_by = xc[1:, :].ravel(), yy[1:, :].ravel()
    ax = np.concatenate([s_ax, c_ax])
    ay = np.concatenate([s_ay, c_ay])
    bx = np.concatenate([s_bx, c_bx])
    by = np.concatenate([s_by, c_by])
    n_s = s_ax.size
    n_seg = ax.size
    out = np.empty((px.size, nl, ns))
    step = max(1, chunk // max(1, 2 * n_seg))
    for p0 in range(0, px.size, step):
        sl = slice(p0, min(px.size, p0 + step))
        # real lattice plus image: the reflected segment runs from B' to A' (strength image_sign)
        v = _segment_wz(px[sl], py[sl], ax, ay, bx, by, cutoff)
        if image_sign != 0.0:
            v += image_sign * _segment_wz(px[sl], py[sl], bx, -by, ax, -ay, cutoff)
        vs = v[:, :n_s].reshape(-1, nl + 1, ns)
        vc = v[:, n_s:].reshape(-1, nl, ns + 1)
        out[sl] = vs[:, :-1, :] - vs[:, 1:, :] + vc[:, :, 1:] - vc[:, :, :-1]
    return out


@dataclass
class UvlmSystem:
    """Assembled nondimensional UVLM of one mesh, Mach number and time step (matrices, no solution)."""

    mach: float
    beta: float
    dt_star: float
    c_ref: float
    n_chord: int
    n_span: int
    n_wake: int  # wake rows kept
    aic_lu: tuple = field(repr=False)  # lu_factor of the bound AIC A0 [K, K]
    aic: np.ndarray = field(repr=False)  # A0 [K, K]
    aic_wake: np.ndarray = field(repr=False)  # AW [K, n_wake, n_span]
    interp_colloc: sp.csr_matrix = field(repr=False)  # [K, N] shape value at collocation points
    ddx_colloc: sp.csr_matrix = field(repr=False)  # [K, N] d/dx of the shape at collocation points (1/m)
    interp_force: sp.csr_matrix = field(repr=False)  # [K, N] shape value at force points
    diff_x: sp.csr_matrix = field(repr=False)  # [K, K] G_p - G_(p upstream)
    dy_hat: np.ndarray = field(repr=False)  # [K] lattice strip width / c_ref
    dx_hat: np.ndarray = field(repr=False)  # [K] panel chord / c_ref
    te: np.ndarray = field(repr=False)  # [n_span] trailing-edge panel indices
    colloc_xy: np.ndarray = field(repr=False)  # [K, 2] physical collocation points (m)
    force_xy: np.ndarray = field(repr=False)  # [K, 2] physical force points (m)
    panel_area: np.ndarray = field(repr=False)  # [K] physical lattice panel areas dx * dy (m^2)
    image_sign: float = 1.0  # the mirror image's strength: +1 symmetric, -1 antisymmetric, 0 none (a free wing)

    @property
    def n_panels(self) -> int:
        """Bound ring count K."""
        return self.n_chord * self.n_span

    def wash_matrices(self, shapes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Nondimensional normal-wash per unit u and per unit du/dt*: (W_disp [K, m], W_vel [K, m])."""
        return self.ddx_colloc @ shapes, (self.interp_colloc @ shapes) / self.c_ref

    def output_matrices(self, shapes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """GAC per unit G and per unit dG/dt*: (C_g [m, K], C_d [m, K]) in m^3 (f = C_g G + C_d G')."""
        phi_f = self.interp_force @ shapes  # [K, m]
        scale = 2.0 * self.c_ref**2
        c_g = scale * (self.diff_x.T @ (phi_f * self.dy_hat[:, None])).T
        c_d = scale * (phi_f * (self.dy_hat * self.dx_hat)[:, None]).T
        return np.asarray(c_g), np.asarray(c_d)


def _interp_matrix(mesh: StandardMesh, s: np.ndarray, t: np.ndarray, derivative: bool) -> sp.csr_matrix:
    """Sparse [K, N] bilinear interpolation (or its x-derivative, 1/m) at panel parameters s (chord), t (span)."""
    nc, ns = mesh.n_chord, mesh.n_span
    j, i = np.divmod(np.arange(nc * ns), nc)
    n00 = j * (nc + 1) + i
    n10, n01 = n00 + 1, n00 + nc + 1
    n11 = n01 + 1
    if derivative:
        jac = (1 - t) * (mesh.x[n10] - mesh.x[n00]) + t * (mesh.x[n11] - mesh.x[n01])
        w = np.column_stack([-(1 - t), 1 - t, -t, t]) / jac[:, None]
    else:
        w = np.column_stack([(1 - s) * (1 - t), s * (1 - t), (1 - s) * t, s * t])
    rows = np.repeat(np.arange(nc * ns), 4)
    cols = np.column_stack([n00, n10, n01, n11]).ravel()
    return sp.csr_matrix((w.ravel(), (rows, cols)), shape=(nc * ns, mesh.n_nodes))


def _ring_grid(
    mesh: StandardMesh, tip_inset: bool, free_root: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Node grid (xn [nc+1, ns+1], yn [ns+1]) and ring corner grid (xr [nc+1, ns+1], yl [ns+1]), lengths / c_ref.

    Ring corners sit a quarter panel chord aft of the nodes. ``tip_inset`` moves the tip's side legs inboard by
    a quarter strip, and the root's too when ``free_root`` (a free wing's root edge is a tip).
    """
    c = mesh.c_ref
    xn = mesh.grid(mesh.x).T / c
    yn = mesh.grid(mesh.y)[:, 0] / c
    dxn = np.diff(xn, axis=0)  # [nc, ns+1]
    xr = np.empty_like(xn)
    xr[:-1] = xn[:-1] + 0.25 * dxn
    xr[-1] = xn[-1] + 0.25 * dxn[-1]
    yl = yn.copy()
    if tip_inset:
        xq = xr.copy()
        yl[-1] = yn[-1] - 0.25 * (yn[-1] - yn[-2])
        xr[:, -1] = xq[:, -2] + 0.75 * (xq[:, -1] - xq[:, -2])
        if free_root:
            yl[0] = yn[0] + 0.25 * (yn[1] - yn[0])
            xr[:, 0] = xq[:, 1] + 0.75 * (xq[:, 0] - xq[:, 1])
    return xn, yn, xr, yl


def build_uvlm(
    mesh: StandardMesh,
    mach: float,
    dt_star: float,
    wake_chords: float = 20.0,
    tip_inset: bool = True,
    symmetry: str = "symmetric",
) -> UvlmSystem:
    """Assemble and LU-factorize the nondimensional UVLM of ``mesh`` at ``mach`` with step ``dt_star``.

    ``wake_chords``: wake length in root chords (rows of length dt_star * c_ref). ``symmetry``: the root's
    (symmetric, antisymmetric, or none: a free wing), the sign of the mirror-image rings and wake
    (``romams_core.aero.protocol.image_sign``). Prandtl-Glauert/Goethert stretch of x by 1/beta; unreliable toward
    M = 1 (see module docstring).
    """
    mach = check_mach(mach)
    dt_star = check_dt_star(dt_star)
    if not (math.isfinite(wake_chords) and wake_chords > 0):
        raise InputError("wake_chords", f"must be a finite number > 0, got {wake_chords!r}")
    sign = image_sign(symmetry)
    beta = math.sqrt(1.0 - mach**2)
    nc, ns, c = mesh.n_chord, mesh.n_span, mesh.c_ref
    n_wake = max(1, int(math.ceil(wake_chords / dt_star - 1e-9)))
    xn, yn, xr, yl = _ring_grid(mesh, tip_inset, free_root=sign == 0.0)
    dxn = np.diff(xn, axis=0)  # [nc, ns+1]
    # panel parameters of collocation (3/4 chord) and force (1/4 chord) points: mid lattice strip
    j, i = np.divmod(np.arange(nc * ns), nc)
    y_mid = 0.5 * (yl[j] + yl[j + 1])
    t = (y_mid - yn[j]) / (yn[j + 1] - yn[j])
    s_c = np.full(nc * ns, 0.75)
    s_f = np.full(nc * ns, 0.25)

    def _pt(s: np.ndarray) -> np.ndarray:
        x00, x10, x01, x11 = xn[i, j], xn[i + 1, j], xn[i, j + 1], xn[i + 1, j + 1]
        return (1 - s) * (1 - t) * x00 + s * (1 - t) * x10 + (1 - s) * t * x01 + s * t * x11

    xc, xf = _pt(s_c), _pt(s_f)
    dx_hat = (1 - t) * dxn[i, j] + t * dxn[i, j + 1]
    dy_hat = yl[j + 1] - yl[j]
    # influence coefficients in the stretched frame
    # _ring_influence returns [P, nL, ns] with ring index (a, b); panel index is b * nc + a
    a0 = _ring_influence(xc / beta, y_mid, xr / beta, yl, image_sign=sign)
    a0 = a0.transpose(0, 2, 1).reshape(nc * ns, nc * ns)
    xw = xr[-1][None, :] + dt_star * np.arange(n_wake + 1)[:, None]
    aw = _ring_influence(xc / beta, y_mid, xw / beta, yl, image_sign=sign)  # [K, n_wake, ns]
    diff_x = sp.eye(nc * ns, format="csr") - sp.eye(nc * ns, k=-1, format="csr")
    lead = np.arange(0, nc * ns, nc)  # leading-edge panels have no upstream ring
    diff_x = sp.lil_matrix(diff_x)
    diff_x[lead[1:], lead[1:] - 1] = 0.0
    return UvlmSystem(
        mach=mach,
        beta=beta,
        dt_star=dt_star,
        c_ref=c,
        n_chord=nc,
        n_span=ns,
        n_wake=n_wake,
        aic_lu=sla.lu_factor(a0),
        aic=a0,
        aic_wake=aw,
        interp_colloc=_interp_matrix(mesh, s_c, t, derivative=False),
        ddx_colloc=_interp_matrix(mesh, s_c, t, derivative=True),
        interp_force=_interp_matrix(mesh, s_f, t, derivative=False),
        diff_x=sp.csr_matrix(diff_x),
        dy_hat=dy_hat,
        dx_hat=dx_hat,
        te=np.arange(ns) * nc + nc - 1,
        colloc_xy=np.column_stack([xc, y_mid]) * c,
        force_xy=np.column_stack([xf, y_mid]) * c,
        panel_area=dx_hat * dy_hat * c**2,
        image_sign=sign,
    )


def bdf2(x: np.ndarray, dt: float) -> np.ndarray:
    """Causal BDF2 time derivative along axis 0 of samples starting from rest (x = 0 before index 0)."""
    x1 = np.zeros_like(x)
    x1[1:] = x[:-1]
    x2 = np.zeros_like(x)
    x2[2:] = x[:-2]
    return (1.5 * x - 2.0 * x1 + 0.5 * x2) / dt


def _window_product(mat: np.ndarray, hist: np.ndarray, nw: int, n_t: int) -> np.ndarray:
    """[T, r, B] = mat [r, nw*ns] times the sliding windows hist[n : n + nw] (time-ordered), chunked GEMMs."""
    ns, n_b = hist.shape[1], hist.shape[2]
    win = sliding_window_view(hist[: n_t + nw - 1], nw, axis=0)  # [T, ns, B, nw], window n = hist[n : n + nw]
    out = np.empty((n_t, mat.shape[0], n_b))
    blk = max(1, 2_000_000 // max(1, nw * ns * n_b))
    for n0 in range(0, n_t, blk):  # memory-bounded chunks of time steps
        w = win[n0 : n0 + blk].transpose(3, 1, 0, 2).reshape(nw * ns, -1)  # rows (s, j), cols (t, b)
        out[n0 : n0 + blk] = (mat @ w).reshape(mat.shape[0], -1, n_b).transpose(1, 0, 2)
    return out


def march(
    system: UvlmSystem,
    wash: np.ndarray | tuple[np.ndarray, np.ndarray],
    progress: ProgressFn | None = None,
    outputs: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """Time-march ring strengths G [T, K, B] (nondimensional) for normal-wash histories wash [T, K, B].

    Step n: wake row 0 holds G_TE(n-1), row r holds G_TE(n-1-r); A0 G(n) = w(n) - AW Gw(n). The only
    sequential part is the recursion on the trailing-edge strengths; all the rest is batched GEMMs. ``wash``
    may be given factored as (W [K, q], inputs [T, q, B]) meaning w = W @ inputs, which is far cheaper.
    With ``outputs`` = (C_g [m, K], C_d [m, K]) return y = C_g G + C_d BDF2(G) [T, m, B] instead of G.
    """
    if isinstance(wash, tuple):
        w_mat, inputs = wash
        q_mat = sla.lu_solve(system.aic_lu, w_mat)  # [K, q]: quasi-steady strengths per unit input
    else:
        q_mat, inputs = None, wash
    n_t, n_b = inputs.shape[0], inputs.shape[2]
    k = system.n_panels
    ns, nw = system.n_span, system.n_wake

    def gq_rows(rows: np.ndarray | slice) -> np.ndarray:
        """Quasi-steady strengths A0^-1 w of the given panels for all steps [T, r, B]."""
        if q_mat is not None:
            return np.matmul(q_mat[rows], inputs)
        full = sla.lu_solve(system.aic_lu, inputs.transpose(1, 0, 2).reshape(k, n_t * n_b))
        return full.reshape(k, n_t, n_b)[rows].transpose(1, 0, 2)

    p = sla.lu_solve(system.aic_lu, system.aic_wake.reshape(k, nw * ns)).reshape(k, nw, ns)
    p_rev = np.ascontiguousarray(p[:, ::-1, :].reshape(k, nw * ns))  # column block s multiplies G_TE(n - nw + s)
    p_te = p_rev[system.te]
    hist = np.zeros((n_t + nw, ns, n_b))
    gq_te = np.ascontiguousarray(gq_rows(system.te))  # [T, ns, B]
    every = max(1, n_t // 20)
    for n in range(n_t):  # the sequential trailing-edge recursion
        hist[n + nw] = gq_te[n] - p_te @ hist[n : n + nw].reshape(nw * ns, n_b)
        if progress is not None and n % every == 0:
            progress(0.9 * n / n_t, f"UVLM time march {n}/{n_t}")
    if outputs is None:
        return gq_rows(slice(None)) - _window_product(p_rev, hist, nw, n_t)
    c_g, c_d = outputs
    if q_mat is not None:  # outputs of the quasi-steady part straight from the inputs
        y = np.matmul(c_g @ q_mat, inputs) + np.matmul(c_d @ q_mat, bdf2(inputs, system.dt_star))
    else:
        gq = gq_rows(slice(None))
        y = np.matmul(c_g, gq) + np.matmul(c_d, bdf2(gq, system.dt_star))
    y -= _window_product(c_g @ p_rev, hist, nw, n_t)
    y -= _window_product(c_d @ p_rev, bdf2(hist, system.dt_star), nw, n_t)
    return y


def _z_wake(system: UvlmSystem, z: complex) -> np.ndarray:
    """Bound AIC with the wake folded in at z: A0 + sum_r AW_r z^-(r+1) on the TE columns [K, K] complex."""
    zr = z ** -(np.arange(system.n_wake) + 1.0)
    m = system.aic.astype(complex)
    m[:, system.te] += np.tensordot(system.aic_wake, zr, axes=([1], [0]))
    return m


def panel_forces_frequency(
    system: UvlmSystem, shapes: np.ndarray, k_values: np.ndarray, derivative: str = "exact"
) -> np.ndarray:
    """Complex panel forces per unit harmonic u: [nk, K, m], in units of rho V^2 c_ref^2 (force up).

    k = omega b / V on the root semichord b = c_ref / 2 (omega* = 2 k in t* units). ``derivative``:
    "exact" (du/dt* = i omega* u, the continuous input) or "bdf2" (as the time march sees sampled signals).
    dG/dt* is always the BDF2 of the march. Uses the wake's z^-(r+1) delay, one K x K solve per k.
    """
    if derivative not in ("exact", "bdf2"):
        raise InputError("derivative", f"must be 'exact' or 'bdf2', got {derivative!r}")
    k_values = np.atleast_1d(np.asarray(k_values, dtype=float))
    w_d, w_v = system.wash_matrices(shapes)
    dt = system.dt_star
    out = np.empty((k_values.size, system.n_panels, shapes.shape[1]), dtype=complex)
    for n, kk in enumerate(k_values):  # loop over a handful of frequencies
        om = 2.0 * kk
        z = np.exp(1j * om * dt)
        g_op = (1.5 - 2.0 / z + 0.5 / z**2) / dt
        d_op = 1j * om if derivative == "exact" else g_op
        g = np.linalg.solve(_z_wake(system, z), w_d + d_op * w_v)
        out[n] = system.dy_hat[:, None] * (system.diff_x @ g + system.dx_hat[:, None] * g_op * g)
    return out


def refine_mesh(mesh: StandardMesh, factor: int) -> tuple[StandardMesh, sp.csr_matrix]:
    """Mesh with every panel split factor x factor, and the sparse [N_fine, N] bilinear map of nodal shapes (m).

    The map is the standard mesh's own panel-wise bilinear interpolant, so the aerodynamic lattice is refined
    without changing the shapes it sees.
    """
    if not (isinstance(factor, int | np.integer) and 1 <= factor <= 8):
        raise InputError("refine", f"must be an integer in [1, 8], got {factor!r}")
    nc, ns = mesh.n_chord, mesh.n_span
    fine = refined_mesh(mesh, factor)  # each panel split in equal parts (a cranked mesh's rows stay its rows)
    if factor == 1:
        return fine, sp.identity(mesh.n_nodes, format="csr")
    jf, i_f = np.divmod(np.arange(fine.n_nodes), nc * factor + 1)
    i = np.minimum(i_f // factor, nc - 1)
    j = np.minimum(jf // factor, ns - 1)
    s_ = (i_f - i * factor) / factor
    t_ = (jf - j * factor) / factor
    n00 = j * (nc + 1) + i
    cols = np.column_stack([n00, n00 + 1, n00 + nc + 1, n00 + nc + 2]).ravel()
    w = np.column_stack([(1 - s_) * (1 - t_), s_ * (1 - t_), (1 - s_) * t_, s_ * t_]).ravel()
    rows = np.repeat(np.arange(fine.n_nodes), 4)
    return fine, sp.csr_matrix((w, (rows, cols)), shape=(fine.n_nodes, mesh.n_nodes))


def frequency_response(
    mesh: StandardMesh,
    shapes: np.ndarray,
    mach: float,
    k_values: np.ndarray,
    dt_star: float | None = None,
    wake_chords: float = 20.0,
    derivative: str = "exact",
    system: UvlmSystem | None = None,
    refine: int = 1,
    symmetry: str = "symmetric",
) -> np.ndarray:
    """Complex GAC transfer matrix H [nk, m, m] (m^3; H[k, i, j] = f_i per unit u_j) at reduced frequencies k.

    k = omega b / V on b = c_ref / 2. ``dt_star`` defaults to 1 / n_chord (of the refined lattice when
    ``refine`` > 1: panels split refine x refine, shapes bilinearly interpolated). Pass a prebuilt ``system``
    (of the mesh actually used) to reuse its factorization; it carries its own root symmetry, otherwise
    ``symmetry`` (symmetric, antisymmetric, none) is the one built.
    """
    shapes = check_shapes(mesh, shapes)
    if refine != 1:
        mesh, interp = refine_mesh(mesh, refine)
        shapes = np.asarray(interp @ shapes)
    if system is None:
        system = build_uvlm(mesh, mach, dt_star or 1.0 / mesh.n_chord, wake_chords=wake_chords, symmetry=symmetry)
    forces = panel_forces_frequency(system, shapes, k_values, derivative)
    phi_f = system.interp_force @ shapes
    return 2.0 * system.c_ref**2 * np.einsum("km,nkj->nmj", phi_f, forces)


def uvlm_state_space(system: UvlmSystem, shapes: np.ndarray) -> DiscreteSS:
    """Full-order discrete state space of the UVLM with displacement input u (BDF2 du/dt*), t* step dt_star.

    x(n) = [G_TE(n-1..n-nw) ; G(n-1) ; G(n-2) ; u(n-1) ; u(n-2)], x(n+1) = A x(n) + B u(n),
    f(n) = C x(n) + D u(n) (GAC, m^3 per unit u; the same numbers as the time march, the predictor removed so
    the input acts at the same step). Size ns*nw + 2K + 2m states: a full-order reference for small meshes
    or short wakes (the flutter code can use it in place of an identified ROM).
    """
    shapes = check_shapes_system(system, shapes)
    k, ns, nw, m = system.n_panels, system.n_span, system.n_wake, shapes.shape[1]
    dt = system.dt_star
    w_d, w_v = system.wash_matrices(shapes)
    c_g, c_d = system.output_matrices(shapes)
    p = sla.lu_solve(system.aic_lu, system.aic_wake.reshape(k, nw * ns))  # [K, nw*ns], row-block r = G_TE(n-1-r)
    q_in = sla.lu_solve(system.aic_lu, np.column_stack([w_d + 1.5 / dt * w_v, -2.0 / dt * w_v, 0.5 / dt * w_v]))
    b0, b1, b2 = q_in[:, :m], q_in[:, m : 2 * m], q_in[:, 2 * m :]
    # G(n) = -P hist(n) + b0 u(n) + b1 u(n-1) + b2 u(n-2)
    nx = nw * ns + 2 * k + 2 * m
    iw, ig1, ig2 = slice(0, nw * ns), slice(nw * ns, nw * ns + k), slice(nw * ns + k, nw * ns + 2 * k)
    iu1, iu2 = slice(nw * ns + 2 * k, nw * ns + 2 * k + m), slice(nw * ns + 2 * k + m, nx)
    g_x = np.zeros((k, nx))  # G(n) = g_x x(n) + b0 u(n)
    g_x[:, iw] = -p
    g_x[:, iu1] = b1
    g_x[:, iu2] = b2
    a = np.zeros((nx, nx))
    b = np.zeros((nx, m))
    # new TE history: row 0 <- G_TE(n), others shift
    a[0:ns, :] = g_x[system.te]
    b[0:ns] = b0[system.te]
    a[ns : nw * ns, 0 : (nw - 1) * ns] = np.eye((nw - 1) * ns)
    a[ig1, :] = g_x
    b[ig1] = b0
    a[ig2, ig1] = np.eye(k)
    b[iu1] = np.eye(m)
    a[iu2, iu1] = np.eye(m)
    # f(n) = c_g G(n) + c_d (1.5 G(n) - 2 G(n-1) + 0.5 G(n-2)) / dt
    cg_tot = c_g + 1.5 / dt * c_d
    c = cg_tot @ g_x
    c[:, ig1] += -2.0 / dt * c_d
    c[:, ig2] += 0.5 / dt * c_d
    d = cg_tot @ b0
    return DiscreteSS(A=a, B=b, C=c, D=d, dt_star=system.dt_star)


def check_shapes_system(system: UvlmSystem, shapes: np.ndarray) -> np.ndarray:
    """Validate shapes [N, m] against the interpolation matrices of a system."""
    arr = np.asarray(shapes, dtype=float)
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim != 2 or arr.shape[0] != system.interp_colloc.shape[1]:
        raise InputError("shapes", f"expected shape [{system.interp_colloc.shape[1]}, m], got {arr.shape}")
    return arr


#: How each root symmetry's image is modelled (the solver's description).
_IMAGE_WORDS = {
    "symmetric": "(mirror-image rings and wake of the same strength)",
    "antisymmetric": "(mirror-image rings and wake of the opposite strength)",
    "none": "(no mirror image: a free wing)",
}


#: Above this Mach number the UVLM's quasi-steady compressibility stretch gives a measured phase error.
UVLM_PHASE_WARNING_MACH = 0.5


def uvlm_warnings(mach: float) -> list[str]:
    """Warnings of UVLM results at ``mach``: the measured unsteady phase error above M 0.5, then the linear ones."""
    out = []
    if mach > UVLM_PHASE_WARNING_MACH:
        out.append(
            f"M = {mach:.3f} > {UVLM_PHASE_WARNING_MACH}: the UVLM's Prandtl-Glauert stretch is exact only as k -> 0; "
            "against the doublet lattice its torsion-driven GAF at k = 0.3 lead in phase by 2-3 deg at M 0.5, "
            "6-10 deg at M 0.79, 9-15 deg at M 0.87 and 23-30 deg at M 0.95, and its flutter pressure is low by "
            "about 1/3 on the cropped delta at M 0.87 (docs/aerodynamics.md); use solver 'dlm' above M 0.5"
        )
    return out + mach_warnings(mach)


@dataclass
class UvlmSolver:
    """Linear UVLM behind the UnsteadySolver protocol (subsonic; Prandtl-Glauert corrected).

    ``refine``: each standard-mesh panel is split refine x refine for the vortex lattice (shapes bilinearly
    interpolated, i.e. the same shapes), and the march runs ``refine`` sub-steps per requested dt_star
    (causal cubic interpolation of the band-limited signals, outputs sampled at the requested steps), so the
    wake rows keep the lattice's panel length. The default 2 is what the damping of chordwise-bending modes
    needs on the 10 x 14 standard mesh (with 1 the cropped delta's 4th mode gets spurious negative
    aerodynamic damping; see docs/aerodynamics.md); 1 reproduces the plain lattice. ``wake_chords``: 10 root
    chords (low-aspect-ratio wings lose < 0.3 % steady lift to the truncation). ``symmetry``: the root's,
    as the DLM's (symmetric, antisymmetric, or none: a free wing), the sign of the mirror-image rings and wake.
    """

    wake_chords: float = 10.0
    tip_inset: bool = True
    refine: int = 2
    name: str = "uvlm"
    symmetry: str = "symmetric"  # of the root plane: symmetric, antisymmetric or none (a free wing)

    def info(self, mach: float) -> SolverInfo:
        """Solver description and the warnings for results at ``mach``."""
        return SolverInfo(
            name=self.name,
            description=(
                f"linear vortex-ring UVLM (lattice refined {self.refine}x, {self.refine} sub-steps), frozen flat "
                f"wake of {self.wake_chords:g} chords, transpiration BC, Prandtl-Glauert/Goethert compressibility, "
                f"root {self.symmetry} " + _IMAGE_WORDS.get(self.symmetry, "")
            ),
            warnings=uvlm_warnings(float(mach)),
        )

    def build(self, mesh: StandardMesh, mach: float, dt_star: float) -> UvlmSystem:
        """Assemble the system for ``mesh`` (used as given, no refinement) at ``mach`` and step ``dt_star``."""
        return build_uvlm(mesh, mach, dt_star, wake_chords=self.wake_chords, tip_inset=self.tip_inset,
                          symmetry=self.symmetry)

    def simulate(
        self,
        mesh: StandardMesh,
        shapes: np.ndarray,
        signals: np.ndarray,
        mach: float,
        dt_star: float,
        progress: ProgressFn | None = None,
    ) -> np.ndarray:
        """GAC [T, m] (m^3) for generalized displacements signals [T, m] of shapes [N, m] (m), from rest.

        A 3-D ``signals`` [T, m, B] runs B independent cases as right-hand-side columns of one march and
        returns [T, m, B]. du/dt* is the causal BDF2 of the (sub-stepped) samples.
        """
        shapes = check_shapes(mesh, shapes)
        dt_star = check_dt_star(dt_star)
        sig = np.asarray(signals, dtype=float)
        batched = sig.ndim == 3
        if batched:
            if sig.shape[1] != shapes.shape[1] or sig.shape[0] < 2 or not np.all(np.isfinite(sig)):
                raise InputError("signals", f"expected finite [T>=2, {shapes.shape[1]}, B], got {sig.shape}")
        else:
            sig = check_signals(sig, shapes.shape[1])[:, :, None]
        if progress is not None:
            progress(0.0, "assembling UVLM influence coefficients")
        r = int(self.refine)
        lattice_mesh, interp = refine_mesh(mesh, r)
        lattice_shapes = np.asarray(interp @ shapes)
        fine = substep_signals(sig, r)
        system = self.build(lattice_mesh, mach, dt_star / r)
        w_d, w_v = system.wash_matrices(lattice_shapes)
        inputs = np.concatenate([fine, bdf2(fine, system.dt_star)], axis=1)  # [T_fine, 2m, B]: u and du/dt*
        wash = (np.hstack([w_d, w_v]), inputs)  # w = W_d u + W_v u', kept factored
        gac = march(system, wash, progress, outputs=system.output_matrices(lattice_shapes))[::r]
        if progress is not None:
            progress(1.0, "UVLM done")
        return gac if batched else gac[:, :, 0]


def substep_signals(signals: np.ndarray, substeps: int) -> np.ndarray:
    """Signals [T, ...] on a grid ``substeps`` times finer ([(T-1) substeps + 1, ...]), causally interpolated.

    Between samples n and n+1 a cubic Lagrange polynomial through samples n-2 .. n+1 (zero before t = 0) is
    used: 4th-order accurate, and the value inside (t_n, t_n+1] depends on no sample later than n+1, so the
    sampled input -> sampled output map stays causal (a global spline would add an anti-causal pole at
    z = -(2 + sqrt 3) that no stable ARX can represent).
    """
    if substeps == 1:
        return signals
    n_t = signals.shape[0]
    pad = np.concatenate([np.zeros((2,) + signals.shape[1:]), signals], axis=0)  # pad[n + 2] = u_n
    out = np.empty(((n_t - 1) * substeps + 1,) + signals.shape[1:])
    out[-1] = signals[-1]
    for q in range(substeps):  # a handful of sub-step phases
        tau = q / substeps
        w = (
            -(tau + 1) * tau * (tau - 1) / 6.0,
            (tau + 2) * tau * (tau - 1) / 2.0,
            -(tau + 2) * (tau + 1) * (tau - 1) / 2.0,
            (tau + 2) * (tau + 1) * tau / 6.0,
        )
        out[q : (n_t - 1) * substeps : substeps] = (
            w[0] * pad[0 : n_t - 1] + w[1] * pad[1:n_t] + w[2] * pad[2 : n_t + 1] + w[3] * pad[3 : n_t + 2]
        )
    return out
