"""PCA (POD) basis of mode shapes on the standard mesh, the modal assurance criterion, projection.

Mode shapes here are out-of-plane displacements at the standard-mesh nodes, arrays [N] or [N, k]
(metres per unit modal coordinate; the basis itself is dimensionless, orthonormal columns).

The basis is built from a snapshot matrix P [N, n] (n = samples x modes, sample-major: the k modes
of sample 0, then those of sample 1, ...). Each snapshot is scaled to unit Euclidean norm and the
thin SVD P = U S V^T gives the basis as the leading columns of U. This is the method of snapshots
of the ROM-AMS paper (eigenvectors of P^T P mapped through P) without squaring the condition
number. Because the columns of U are orthonormal, the least-squares fit of a unit snapshot p by
the first m of them has MAC = sum_{i <= m} (u_i . p)^2, so the MAC of every snapshot for every m
comes from one cumulative sum of (S V^T)^2.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.stats import qmc

from romams_core.errors import InputError
from romams_core.validation import check_int, check_unit_interval

ProgressFn = Callable[[float, str], None]
MapFn = Callable[[Callable[[np.ndarray], np.ndarray], Iterable[np.ndarray]], Iterable[np.ndarray]]


def _as_2d(name: str, a: np.ndarray) -> np.ndarray:
    """Float [N, k] view of a [N] or [N, k] array; ValueError naming ``name`` if not finite."""
    arr = np.asarray(a, dtype=float)
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim != 2:
        raise InputError(name, f"expected a [N] or [N, k] array, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(name, "contains NaN or infinite values")
    return arr


def mac(a: np.ndarray, b: np.ndarray) -> np.ndarray | float:
    """Modal assurance criterion (dimensionless, 0..1) of matching columns of a and b ([N] or [N, k]).

    MAC = (a.b)^2 / ((a.a)(b.b)); column i of ``a`` is compared with column i of ``b``. Two 1-D
    inputs give a float, [N, k] inputs give [k]. A zero column gives MAC 0.
    """
    one_d = np.ndim(a) == 1 and np.ndim(b) == 1
    a2, b2 = _as_2d("a", a), _as_2d("b", b)
    if a2.shape != b2.shape:
        raise InputError("b", f"shape {b2.shape} does not match a's shape {a2.shape}")
    ab = np.einsum("ij,ij->j", a2, b2)
    den = np.einsum("ij,ij->j", a2, a2) * np.einsum("ij,ij->j", b2, b2)
    out = np.divide(ab * ab, den, out=np.zeros_like(ab), where=den > 0.0)
    return float(out[0]) if one_d else out


def mac_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """MAC (dimensionless) of every column of a [N, ka] against every column of b [N, kb] -> [ka, kb]."""
    a2, b2 = _as_2d("a", a), _as_2d("b", b)
    if a2.shape[0] != b2.shape[0]:
        raise InputError("b", f"has {b2.shape[0]} rows, a has {a2.shape[0]}")
    ab = a2.T @ b2
    den = np.outer(np.einsum("ij,ij->j", a2, a2), np.einsum("ij,ij->j", b2, b2))
    return np.divide(ab * ab, den, out=np.zeros_like(ab), where=den > 0.0)


def _bounds(wing: Any) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper bounds [d] (each variable's own unit) of a wing's design variables."""
    dvs = tuple(getattr(wing, "design_variables", ()) or ())
    if not dvs:
        raise InputError("wing.design_variables", "the wing has no design variables to sample")
    lower = np.array([float(v.lower) for v in dvs])
    upper = np.array([float(v.upper) for v in dvs])
    if not (np.all(np.isfinite(lower)) and np.all(np.isfinite(upper)) and np.all(upper >= lower)):
        raise InputError("wing.design_variables", "bounds must be finite with lower <= upper")
    return lower, upper


def sample_designs(wing: Any, n: int, seed: int = 0) -> np.ndarray:
    """Latin hypercube sample [n, d] of the wing's design space (each variable in its own unit)."""
    n = check_int("samples", n, 1, 100_000)
    lower, upper = _bounds(wing)
    unit = qmc.LatinHypercube(d=lower.size, rng=np.random.default_rng(seed)).random(n)
    return lower + unit * (upper - lower)


def random_designs(wing: Any, n: int, seed: int = 1) -> np.ndarray:
    """Independent uniform random designs [n, d] in the wing's bounds (for hold-out checks)."""
    n = check_int("holdout", n, 1, 100_000)
    lower, upper = _bounds(wing)
    return lower + np.random.default_rng(seed).random((n, lower.size)) * (upper - lower)


def snapshot(wing: Any, design: np.ndarray | Sequence[float] | None, n_modes: int = 4) -> np.ndarray:
    """Mass-normalized mode shapes [N, n_modes] (m) of one design on the wing's standard mesh.

    A pure function of its arguments, so that the modal analyses of the samples can be spread
    over processes or workers.
    """
    from romams_core.structure.modal import modal_analysis  # written by the structure part

    n_modes = check_int("modes", n_modes, 1, 50)
    res = modal_analysis(wing, design=None if design is None else np.asarray(design, dtype=float), n_modes=n_modes)
    return np.asarray(res.shapes, dtype=float)


@dataclass
class Basis:
    """PCA basis of mode shapes (orthonormal columns on the standard mesh) and its fit quality."""

    shapes: np.ndarray  # [N, m] basis shapes, orthonormal columns (dimensionless)
    singular_values: np.ndarray  # [r] singular values of the unit-norm snapshot matrix
    n_basis: int  # m
    mac_threshold: float  # epsilon used to choose m
    max_basis: int  # user cap on m
    min_mac: float  # worst snapshot MAC with m shapes
    min_mac_by_m: np.ndarray  # [max_basis] worst snapshot MAC with 1..max_basis shapes
    mac_table: np.ndarray  # [n_snap] MAC of each snapshot's fit with m shapes
    capped: bool  # True if the threshold was not reached within max_basis (m = cap)
    n_modes: int  # modes per sample structure (k); snapshots are sample-major
    designs: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))  # [n, d] sample designs
    design_names: list[str] = field(default_factory=list)
    wing_name: str = ""
    energy: np.ndarray = field(default_factory=lambda: np.zeros(0))  # [r] cumulative energy fraction
    candidates: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))  # [N, <= max_basis] leading shapes

    @property
    def n_nodes(self) -> int:
        """Number of standard-mesh nodes N."""
        return int(self.shapes.shape[0])

    @property
    def mac_by_m(self) -> np.ndarray:
        """Alias of ``min_mac_by_m``: worst snapshot MAC [max_basis] with 1..max_basis shapes."""
        return self.min_mac_by_m

    @property
    def mac_by_mode(self) -> np.ndarray:
        """Snapshot MACs at m as [n_samples, n_modes] (dimensionless)."""
        return self.mac_table.reshape(-1, self.n_modes)

    @property
    def message(self) -> str:
        """One-line summary, saying so when the cap was hit."""
        s = f"{self.n_basis} basis shapes, worst snapshot MAC {self.min_mac:.5f} (threshold {self.mac_threshold})"
        if self.capped:
            s += f"; threshold NOT reached: capped at max_basis = {self.max_basis}"
        return s


def _canonical_sign(shapes: np.ndarray) -> np.ndarray:
    """Flip columns [N, k] so that each column's largest-magnitude entry is positive."""
    idx = np.argmax(np.abs(shapes), axis=0)
    s = np.sign(shapes[idx, np.arange(shapes.shape[1])])
    s[s == 0] = 1.0
    return shapes * s


def build_basis(
    snapshots: np.ndarray,
    mac_threshold: float = 0.98,
    max_basis: int = 12,
    *,
    n_modes: int | None = None,
    designs: np.ndarray | None = None,
    design_names: Sequence[str] = (),
    wing_name: str = "",
) -> Basis:
    """PCA basis from snapshots [N, n] (m): smallest m whose fit of every snapshot has MAC >= threshold.

    m is capped by ``max_basis`` and by the snapshot rank; if the threshold is not reached the
    result has ``capped=True`` and says so in ``message``.
    """
    p = _as_2d("snapshots", snapshots)
    n_nodes, n_snap = p.shape
    thr = check_unit_interval("mac_threshold", mac_threshold)
    max_basis = check_int("max_basis", max_basis, 1, 1000)
    if n_snap < 1 or n_nodes < 2:
        raise InputError("snapshots", f"need at least 2 nodes and 1 snapshot, got shape {p.shape}")
    norms = np.linalg.norm(p, axis=0)
    if np.any(norms <= 1e-300):
        bad = np.flatnonzero(norms <= 1e-300).tolist()
        raise InputError("snapshots", f"columns {bad[:10]} are zero (a mode shape must be non-zero)")
    k = n_snap if n_modes is None else check_int("n_modes", n_modes, 1, n_snap)
    if n_snap % k:
        raise InputError("n_modes", f"{k} does not divide the {n_snap} snapshots")
    pn = p / norms
    u, s, vt = np.linalg.svd(pn, full_matrices=False)
    # numerical rank: directions with singular value above round-off
    rank = max(1, int(np.sum(s > s[0] * max(n_nodes, n_snap) * np.finfo(float).eps)))
    coef2 = (s[:rank, None] * vt[:rank]) ** 2  # [rank, n_snap] squared coefficients of unit snapshots
    mac_cum = np.minimum(np.cumsum(coef2, axis=0), 1.0)  # [rank, n_snap] MAC with 1..rank shapes
    worst = mac_cum.min(axis=1)
    reached = np.flatnonzero(worst >= thr)
    m_cap = min(max_basis, rank)
    capped = not (reached.size and reached[0] + 1 <= m_cap)
    m = m_cap if capped else int(reached[0] + 1)
    min_by_m = worst[np.minimum(np.arange(max_basis), rank - 1)]
    energy = np.cumsum(s**2) / np.sum(s**2)
    d = np.zeros((0, 0)) if designs is None else np.atleast_2d(np.asarray(designs, dtype=float))
    cand = _canonical_sign(u[:, :m_cap].copy())
    return Basis(
        shapes=cand[:, :m].copy(),
        singular_values=s.copy(),
        n_basis=m,
        mac_threshold=thr,
        max_basis=max_basis,
        min_mac=float(worst[m - 1]),
        min_mac_by_m=min_by_m,
        mac_table=mac_cum[m - 1].copy(),
        capped=bool(capped),
        n_modes=k,
        designs=d,
        design_names=[str(x) for x in design_names],
        wing_name=str(wing_name),
        energy=energy,
        candidates=cand,
    )


def mac_by_basis_size(candidates: np.ndarray, shapes: np.ndarray) -> np.ndarray:
    """MAC [M, k] of the fit of shapes [N, k] by the first 1..M orthonormal candidate shapes [N, M]."""
    v = _as_2d("candidates", candidates)
    phi = _as_2d("shapes", shapes)
    if v.shape[0] != phi.shape[0]:
        raise InputError("shapes", f"has {phi.shape[0]} nodes, the candidates have {v.shape[0]}")
    c2 = (v.T @ phi) ** 2
    norm2 = np.einsum("ij,ij->j", phi, phi)
    return np.minimum(np.cumsum(c2, axis=0) / np.where(norm2 > 0.0, norm2, 1.0), 1.0)


@dataclass
class Projection:
    """Least-squares fit of mode shapes by basis shapes: Phi ~ V gamma."""

    gamma: np.ndarray  # [m, k] coefficients (m per unit modal coordinate, as the shapes)
    mac: np.ndarray  # [k] MAC of each fitted mode against the original
    fitted: np.ndarray  # [N, k] V gamma
    mac_threshold: float  # threshold used for the flag
    poor_fit: list[bool]  # per mode: MAC < threshold
    min_mac: float  # worst MAC over the modes

    @property
    def ok(self) -> bool:
        """True when every mode fits with MAC >= threshold."""
        return not any(self.poor_fit)


def project(basis_shapes: np.ndarray, shapes: np.ndarray, mac_threshold: float = 0.98) -> Projection:
    """Least-squares coefficients gamma [m, k] of shapes [N, k] in basis_shapes [N, m], with fit MACs.

    Orthonormal bases (the PCA basis) use gamma = V^T Phi; any other full-rank basis falls back to
    a least-squares solve. Modes with MAC < ``mac_threshold`` are flagged in ``poor_fit``.
    """
    v = _as_2d("basis_shapes", basis_shapes)
    phi = _as_2d("shapes", shapes)
    thr = check_unit_interval("mac_threshold", mac_threshold)
    if v.shape[0] != phi.shape[0]:
        raise InputError("shapes", f"has {phi.shape[0]} nodes, the basis has {v.shape[0]}")
    if v.shape[1] > v.shape[0]:
        raise InputError("basis_shapes", f"more shapes ({v.shape[1]}) than nodes ({v.shape[0]})")
    gram = v.T @ v
    if np.allclose(gram, np.eye(v.shape[1]), rtol=0.0, atol=1e-10):
        gamma = v.T @ phi
    else:
        gamma, _, rank, _ = np.linalg.lstsq(v, phi, rcond=None)
        if rank < v.shape[1]:
            raise InputError("basis_shapes", f"rank deficient ({rank} < {v.shape[1]} shapes)")
    fitted = v @ gamma
    macs = np.atleast_1d(mac(fitted, phi))
    return Projection(
        gamma=gamma,
        mac=macs,
        fitted=fitted,
        mac_threshold=thr,
        poor_fit=[bool(x < thr) for x in macs],
        min_mac=float(macs.min()) if macs.size else math.nan,
    )


def build_basis_for_wing(
    wing: Any,
    samples: int = 25,
    modes: int = 4,
    mac_threshold: float = 0.98,
    max_basis: int = 12,
    seed: int = 0,
    progress: ProgressFn | None = None,
    map_fn: MapFn | None = None,
) -> Basis:
    """Sample the design space (LHS), run the modal analyses and build the PCA basis.

    ``map_fn`` (e.g. an executor's ``map``) may spread the per-sample modal analyses; ``progress``
    gets (fraction 0..1, message) and may raise to cancel.
    """
    check_unit_interval("mac_threshold", mac_threshold)
    check_int("max_basis", max_basis, 1, 1000)
    modes = check_int("modes", modes, 1, 50)
    designs = sample_designs(wing, samples, seed)
    if progress:
        progress(0.0, f"modal analysis of {samples} sample structures")

    def one(x: np.ndarray) -> np.ndarray:
        return snapshot(wing, x, modes)

    results = map_fn(one, list(designs)) if map_fn is not None else None
    snaps: list[np.ndarray] = []
    it = iter(results) if results is not None else (one(x) for x in designs)
    for i, shp in enumerate(it):
        snaps.append(np.asarray(shp, dtype=float))
        if progress:
            progress(0.95 * (i + 1) / samples, f"sample {i + 1}/{samples}")
    basis = build_basis(
        np.hstack(snaps),
        mac_threshold=mac_threshold,
        max_basis=max_basis,
        n_modes=modes,
        designs=designs,
        design_names=[v.name for v in wing.design_variables],
        wing_name=str(getattr(wing, "name", "")),
    )
    if progress:
        progress(1.0, basis.message)
    return basis


def holdout_macs(wing: Any, basis_shapes: np.ndarray, designs: np.ndarray, n_modes: int = 4) -> np.ndarray:
    """MAC [n, n_modes] of the basis fit of each design's first modes (dimensionless)."""
    designs = np.atleast_2d(np.asarray(designs, dtype=float))
    return np.vstack([np.atleast_1d(project(basis_shapes, snapshot(wing, x, n_modes), 0.5).mac) for x in designs])
