"""Doublet-lattice method (DLM) in the frequency domain on the standard mesh, wrapping DLR's ``panelaero``.

Model (derivation and verification in docs/aerodynamics.md, section 10):
- one box per (optionally refined) standard-mesh panel: doublet line on the 1/4-chord line (load point at its
  midpoint), collocation at 3/4 chord mid-span, normal +z, every box defined left to right (P1 at smaller y);
- the root y = 0 is a plane of symmetry: the lattice is mirrored explicitly (left boxes also left to right,
  normal +z) and the symmetric AIC of the half wing is D_sym = D_RR + D_RL, the receiving rows of the full
  lattice's AIC summed over each box and its image (panelaero's own ``xz_symmetry`` is not used, see the tests);
- AIC D(k) = D_VLM + dD_DLM(k) (panelaero's steady horseshoe VLM with the Prandtl-Glauert stretch, plus the
  Rodden parabolic DLM increment: compiled for the planar lattice in :mod:`.dlm_kernel`, equal to panelaero's
  ``calc_Ajj`` to round-off, tests/test_dlm.py); D maps the pressure coefficient cp (positive up) of every box
  to the normal velocity / V it induces at every collocation point;
- boundary condition D cp = w / V with w / V = dh/dx + i k h / b (h the +z displacement of the surface,
  e^{i omega t} convention, k = omega b / V on b = c_ref / 2); h and dh/dx from the standard mesh's bilinear
  interpolant of the nodal shape values (as the UVLM);
- GAC H[k, i, j] = sum over boxes of phi_i(load point) cp_j A (m^3 for shapes in m), i.e. f = (1/q) int dp phi dS.

Grid unit: panelaero's VLM drops a bound vortex whose |r1 x r2| is below an absolute 1e-5 (grid units^2); in
metres that removes the self-influence of the small boxes of a refined model-scale wing (cropped delta, refine
>= 3: 30 % AIC errors). The aerogrid is therefore built in units of c_ref / 1000 (``unit`` m), where boxes
measure ~1000 / (n_chord refine) units and the threshold never bites. panelaero's reduced frequency is
omega / V per grid unit: it receives k unit / b.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from types import ModuleType
from typing import Any

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from romams_core.aero.dlm_kernel import planar_dlm_increment
from romams_core.aero.protocol import (
    ProgressFn,
    SolverInfo,
    check_k_values,
    check_mach,
    check_shapes,
    image_sign,
    mach_warnings,
)
from romams_core.aero.uvlm import _interp_matrix, refine_mesh
from romams_core.mesh import StandardMesh

__all__ = [
    "DlmSystem",
    "DlmSolver",
    "build_aerogrid",
    "mirror_aerogrid",
    "aic_rows",
    "build_dlm",
    "frequency_response",
]

#: Keys of a panelaero aerogrid that describe the sending boxes (the receivers are ``offset_j``).
_BOX_KEYS = ("offset_l", "offset_k", "offset_P1", "offset_P3", "N", "A", "l")
#: Grid units per reference chord (see the module docstring).
_UNITS_PER_CHORD = 1000.0
#: Bounded caches (least recently used dropped first): assembled systems per (lattice, Mach) and factorized
#: AICs per (lattice, Mach, k). The sizes bound memory (K = 560 boxes: 5 MB per factorization, 2.5 MB per system).
#: 12 systems hold a 10-Mach envelope, so the projection correction's DLM (three k per Mach and structure,
#: ``romams_core.projection_residual``) is assembled once per Mach, not once per structure and Mach.
SYSTEM_CACHE_SIZE = 12
LU_CACHE_SIZE = 48
_SYSTEM_CACHE: dict[tuple[Any, ...], DlmSystem] = {}
_LU_CACHE: dict[tuple[Any, ...], tuple[np.ndarray, np.ndarray]] = {}
#: Tile edge of the AIC blocks handed to panelaero (its kernels are square [n, n] arrays; tiles bound memory).
_TILE = 300


def _panelaero() -> tuple[ModuleType, ModuleType]:
    """panelaero's (VLM, DLM) modules, imported with numpy's global error state restored afterwards."""
    old = np.geterr()
    try:
        from panelaero import DLM, VLM  # its import calls np.seterr(all="ignore") for the whole process
    finally:
        np.seterr(**old)
    return VLM, DLM


def build_aerogrid(mesh: StandardMesh) -> dict[str, Any]:
    """panelaero aerogrid of the mesh's panels in grid units (``"unit"`` m each; box p = j * n_chord + i), half wing."""
    unit = mesh.c_ref / _UNITS_PER_CHORD
    xg, yg = mesh.grid(mesh.x) / unit, mesh.grid(mesh.y) / unit  # [ns+1, nc+1]
    x00, x10, x01, x11 = xg[:-1, :-1], xg[:-1, 1:], xg[1:, :-1], xg[1:, 1:]
    y00, y10, y01, y11 = yg[:-1, :-1], yg[:-1, 1:], yg[1:, :-1], yg[1:, 1:]

    def edge_pts(s: float) -> tuple[np.ndarray, np.ndarray]:
        """Points at chord fraction s on the inboard and outboard box edges, [K, 3] each."""
        zero = np.zeros(x00.size)
        p_in = np.column_stack([(x00 + s * (x10 - x00)).ravel(), (y00 + s * (y10 - y00)).ravel(), zero])
        p_out = np.column_stack([(x01 + s * (x11 - x01)).ravel(), (y01 + s * (y11 - y01)).ravel(), zero])
        return p_in, p_out

    p1, p3 = edge_pts(0.25)
    area = 0.5 * np.abs((x11 - x00) * (y01 - y10) - (y11 - y00) * (x01 - x10)).ravel()  # shoelace, diagonals
    n = area.size
    return {
        "offset_j": 0.5 * np.add(*edge_pts(0.75)),
        "offset_l": 0.5 * (p1 + p3),
        "offset_k": 0.5 * np.add(*edge_pts(0.5)),
        "offset_P1": p1,
        "offset_P3": p3,
        "N": np.tile([0.0, 0.0, 1.0], (n, 1)),
        "A": area,
        "l": 0.5 * ((x10 - x00) + (x11 - x01)).ravel(),
        "n": n,
        "unit": unit,
    }


def mirror_aerogrid(grid: dict[str, Any]) -> dict[str, Any]:
    """Full lattice (grid units): the half-wing boxes, then their images about y = 0 (left to right, normals +z)."""
    flip = np.array([1.0, -1.0, 1.0])
    left = {
        "offset_j": grid["offset_j"] * flip,
        "offset_l": grid["offset_l"] * flip,
        "offset_k": grid["offset_k"] * flip,
        "offset_P1": grid["offset_P3"] * flip,  # the image of the outboard end is the left end
        "offset_P3": grid["offset_P1"] * flip,
        "N": grid["N"].copy(),
        "A": grid["A"].copy(),
        "l": grid["l"].copy(),
    }
    full = {key: np.concatenate([grid[key], left[key]]) for key in left}
    full["n"] = 2 * grid["n"]
    full["unit"] = grid["unit"]
    return full


def aic_rows(receivers: np.ndarray, boxes: dict[str, Any], mach: float, k_panelaero: float | None) -> np.ndarray:
    """AIC rows [R, S]: normal velocity / V at receivers [R, 3] per unit cp of each sending box (grid units).

    ``k_panelaero`` None gives panelaero's steady VLM part, a number omega / V (per grid unit) its DLM increment
    (the reference of the compiled planar kernel the solver uses, :func:`.dlm_kernel.planar_dlm_increment`).
    panelaero evaluates square [n, n] arrays, so the matrix is built in square tiles (the last ones padded by
    repetition; every entry depends only on its receiver and its box, and the lattice is planar).
    """
    vlm, dlm = _panelaero()
    n_r, n_s = receivers.shape[0], boxes["A"].size
    out = np.zeros((n_r, n_s), dtype=float if k_panelaero is None else complex)
    for r0 in range(0, n_r, _TILE):  # loops over tiles of a few hundred boxes, not over boxes
        ri = np.arange(r0, min(n_r, r0 + _TILE))
        for s0 in range(0, n_s, _TILE):
            si = np.arange(s0, min(n_s, s0 + _TILE))
            size = max(ri.size, si.size)
            tile = {key: np.asarray(boxes[key])[np.resize(si, size)] for key in _BOX_KEYS}
            tile["offset_j"] = receivers[np.resize(ri, size)]
            tile["n"] = size
            with np.errstate(all="ignore"):
                block = vlm.calc_Ajj(tile, mach)[0] if k_panelaero is None else dlm.calc_Ajj(tile, mach, k_panelaero)
            out[ri[0] : ri[-1] + 1, si[0] : si[-1] + 1] = block[: ri.size, : si.size]
    return out


@dataclass
class DlmSystem:
    """Assembled DLM of one (lattice) mesh at one Mach number: geometry, interpolation, steady symmetric AIC."""

    mach: float
    b_ref: float  # reference semichord c_ref / 2 (m)
    grid: dict[str, Any] = field(repr=False)  # half-wing aerogrid (grid units of grid["unit"] m)
    full: dict[str, Any] = field(repr=False)  # explicitly mirrored full lattice (grid units)
    steady: np.ndarray = field(repr=False)  # [K, K] steady AIC D_RR + sign D_RL (VLM part)
    interp_colloc: sp.csr_matrix = field(repr=False)  # [K, N] shape value at collocation points
    ddx_colloc: sp.csr_matrix = field(repr=False)  # [K, N] d/dx of the shape at collocation points (1/m)
    interp_load: sp.csr_matrix = field(repr=False)  # [K, N] shape value at load points (1/4-chord midpoints)

    key: tuple[Any, ...] = ()  # lattice fingerprint, Mach and symmetry: the key of the factorized-AIC cache
    image_sign: float = 1.0  # the mirror image's loading: +1 symmetric, -1 antisymmetric, 0 none (a free wing)

    @property
    def n_boxes(self) -> int:
        """Box count K of the half wing."""
        return int(self.grid["n"])

    def lu(self, k: float) -> tuple[np.ndarray, np.ndarray]:
        """LU factors of the symmetric AIC at reduced frequency k, from the bounded module cache when present."""
        key = (*self.key, float(k))
        hit = _LU_CACHE.pop(key, None) if self.key else None
        if hit is None:
            hit = sla.lu_factor(self.aic(float(k)))
        if self.key:
            _LU_CACHE[key] = hit  # most recent last
            while len(_LU_CACHE) > LU_CACHE_SIZE:
                _LU_CACHE.pop(next(iter(_LU_CACHE)))
        return hit

    @property
    def area(self) -> np.ndarray:
        """Box areas [K] (m^2)."""
        return np.asarray(self.grid["A"]) * self.grid["unit"] ** 2

    def symmetric(self, rows: np.ndarray) -> np.ndarray:
        """AIC [K, K] of the wing's symmetry from full-lattice rows [K, 2K]: each box plus ``image_sign`` times its
        mirror image (symmetric: the same loading on the image; antisymmetric: the opposite; none: no image)."""
        k = self.n_boxes
        return rows[:, :k] + self.image_sign * rows[:, k:]

    def aic(self, k: float) -> np.ndarray:
        """AIC D(k) [K, K] (normal velocity / V per unit cp) at reduced frequency k on b_ref, of the symmetry."""
        if k == 0.0:
            return self.steady.astype(complex)
        k_grid = float(k) * self.grid["unit"] / self.b_ref  # omega / V per grid unit
        unsteady = planar_dlm_increment(self.grid["offset_j"], self.full, self.mach, k_grid)
        return self.steady + self.symmetric(unsteady)

    def wash(self, shapes: np.ndarray, k: float) -> np.ndarray:
        """Normal-wash / V [K, m] per unit harmonic u of shapes [N, m] (m): dh/dx + i k h / b_ref."""
        return np.asarray(self.ddx_colloc @ shapes) + (1j * k / self.b_ref) * np.asarray(self.interp_colloc @ shapes)

    def pressures(
        self, shapes: np.ndarray, k_values: np.ndarray, progress: ProgressFn | None = None
    ) -> np.ndarray:
        """Box pressure coefficients cp [nk, K, m] (positive up) per unit harmonic u of shapes [N, m] (m)."""
        k_values = check_k_values(k_values)
        out = np.empty((k_values.size, self.n_boxes, shapes.shape[1]), dtype=complex)
        for n, k in enumerate(k_values):  # one AIC and one solve per reduced frequency
            if progress is not None:
                progress(n / k_values.size, f"DLM reduced frequency {n + 1}/{k_values.size} (k = {k:g})")
            out[n] = sla.lu_solve(self.lu(float(k)), self.wash(shapes, float(k)))
        if progress is not None:
            progress(1.0, "DLM done")
        return out

    def gaf(self, shapes: np.ndarray, k_values: np.ndarray, progress: ProgressFn | None = None) -> np.ndarray:
        """Complex GAC H [nk, m, m] (m^3) of lattice-mesh shapes [N, m] (m): sum phi_i(load) cp_j A."""
        cp = self.pressures(shapes, k_values, progress)
        phi_a = np.asarray(self.interp_load @ shapes) * self.area[:, None]  # [K, m]
        return np.einsum("pi,npj->nij", phi_a, cp)


def _fingerprint(mesh: StandardMesh) -> tuple[Any, ...]:
    """Hashable identity of a lattice mesh (node coordinates and counts)."""
    xy = np.ascontiguousarray(np.column_stack([mesh.x, mesh.y]), dtype=float)
    return (mesh.n_chord, mesh.n_span, hashlib.sha1(xy.tobytes()).hexdigest())


def build_dlm(mesh: StandardMesh, mach: float, symmetry: str = "symmetric") -> DlmSystem:
    """Assemble the DLM of ``mesh`` (one box per panel, no refinement) at subsonic ``mach`` for the root
    ``symmetry`` (symmetric, antisymmetric, or none: a free wing); steady AIC included.

    Systems of the same lattice and Mach are cached (``SYSTEM_CACHE_SIZE``), and so are the factorized AICs of
    each reduced frequency (``LU_CACHE_SIZE``, about 5 MB each on the default cropped-delta lattice): a second set
    of shapes on the same wing and Mach (ROM-PMS, the full-order p-k) costs only the solves.
    """
    mach = check_mach(mach, upper=1.0)
    sign = image_sign(symmetry)
    key = (*_fingerprint(mesh), mach, sign)
    cached = _SYSTEM_CACHE.pop(key, None)
    if cached is None:
        cached = _build_dlm(mesh, mach, sign)
        cached.key = key
    _SYSTEM_CACHE[key] = cached
    while len(_SYSTEM_CACHE) > SYSTEM_CACHE_SIZE:
        _SYSTEM_CACHE.pop(next(iter(_SYSTEM_CACHE)))
    return cached


def _build_dlm(mesh: StandardMesh, mach: float, sign: float = 1.0) -> DlmSystem:
    """Assemble the DLM of ``mesh`` at ``mach`` with mirror-image loading ``sign`` (no cache)."""
    grid = build_aerogrid(mesh)
    full = mirror_aerogrid(grid)
    n = grid["n"]
    s_c, s_l, t = np.full(n, 0.75), np.full(n, 0.25), np.full(n, 0.5)
    steady_rows = aic_rows(grid["offset_j"], full, mach, None)
    return DlmSystem(
        mach=mach,
        b_ref=0.5 * mesh.c_ref,
        grid=grid,
        full=full,
        steady=steady_rows[:, :n] + sign * steady_rows[:, n:],
        interp_colloc=_interp_matrix(mesh, s_c, t, derivative=False),
        ddx_colloc=_interp_matrix(mesh, s_c, t, derivative=True),
        interp_load=_interp_matrix(mesh, s_l, t, derivative=False),
        image_sign=float(sign),
    )


def frequency_response(
    mesh: StandardMesh,
    shapes: np.ndarray,
    mach: float,
    k_values: np.ndarray,
    refine: int = 2,
    progress: ProgressFn | None = None,
    symmetry: str = "symmetric",
) -> np.ndarray:
    """DLM GAC H [nk, m, m] (m^3; H[k, i, j] = f_i per unit u_j) of shapes [N, m] (m) at k = omega c_ref / (2 V).

    The lattice splits every standard-mesh panel refine x refine (shapes bilinearly interpolated, as the UVLM).
    """
    mach = check_mach(mach, upper=1.0)
    shapes = check_shapes(mesh, shapes)
    k_values = check_k_values(k_values)
    lattice, interp = refine_mesh(mesh, refine)
    if progress is not None:
        progress(0.0, "assembling the steady DLM (VLM) influence coefficients")
    system = build_dlm(lattice, mach, symmetry)
    return system.gaf(np.asarray(interp @ shapes), k_values, progress)


def zero_box(d_lo: np.ndarray, d_hi: np.ndarray, r_lo: int, r_hi: int) -> np.ndarray:
    """GAC tables (m^3) of lattices refined r_lo < r_hi times, extrapolated to zero box size: the DLM's error
    falls as the box size 1 / r (first order; docs/aerodynamics.md 13.4), so r_hi D_hi - r_lo D_lo over
    r_hi - r_lo."""
    return (r_hi * np.asarray(d_hi) - r_lo * np.asarray(d_lo)) / (r_hi - r_lo)


@dataclass
class DlmSolver:
    """Subsonic doublet-lattice method behind the FrequencySolver protocol (panelaero kernels, explicit mirror).

    ``refine``: each standard-mesh panel is split refine x refine into DLM boxes (the shapes are the same,
    bilinearly interpolated). On the cropped delta (8 modes, M 0.5, k 0.1 .. 1.5) the largest GAC error
    relative to the largest entry, against the 4x lattice, is 8.5-9.4 % (refine 1), 2.9-3.3 % (2) and 1.0-1.1 %
    (3); the default 2 runs 14 frequencies in about 10 s on one core, 3 would take five times longer.
    """

    refine: int = 2
    name: str = "dlm"
    symmetry: str = "symmetric"  # of the root plane: symmetric, antisymmetric or none (a free wing)

    def info(self, mach: float) -> SolverInfo:
        """Solver description and the warnings for results at ``mach``."""
        return SolverInfo(
            name=self.name,
            description=(
                f"subsonic doublet-lattice method (panelaero: steady VLM plus Rodden parabolic DLM increment), "
                f"lattice refined {self.refine}x, root {self.symmetry} "
                + ("(no mirror image: a free wing)" if self.symmetry == "none" else "by an explicitly mirrored lattice")
            ),
            warnings=mach_warnings(float(mach)),
        )

    def gaf(
        self,
        mesh: StandardMesh,
        shapes: np.ndarray,
        mach: float,
        k_values: np.ndarray,
        progress: ProgressFn | None = None,
    ) -> np.ndarray:
        """Complex GAC H [nk, m, m] (m^3) of shapes [N, m] (m) at k = omega c_ref / (2 V); M < 1 only."""
        return frequency_response(mesh, shapes, mach, k_values, refine=self.refine, progress=progress,
                                  symmetry=self.symmetry)
