"""AGARD 445.6 weakened wing 3: where the equivalent-plate frequencies come from (docs/structure.md, section 4).

Not run by the tests (the tests import ``kirchhoff_ritz`` and ``mode_character``). Prints JSON with:

* the template's frequencies on FE meshes from 8 x 10 to 64 x 80 cells;
* an independent Rayleigh-Ritz solution of the same plate (Legendre polynomials on the mapped
  trapezoid, exact thickness form by Gauss quadrature), Kirchhoff and Reissner-Mindlin (transverse
  shear with G13 = G23 = f * G12, plate rotary inertia included);
* the modelling choices the plate could get wrong: the edge thickness floor, E1 orientation, a root
  clamped over part of the chord, the published vs Yates' weakened-model E and G;
* the single equivalent-plate constant that Yates' modes 2-5 identify (G12, density re-tuned to mode 1)
  and the bending / twist strain-energy split of each mode.

Frequencies are compared with Yates' calculated modes after scaling mode 1 to 9.60 Hz (a density
re-tune), so the numbers show what the density cannot fix.

Usage: python -m benchmarks.agard_structure_study
"""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
from numpy.polynomial import legendre
from scipy.linalg import eigh
from scipy.optimize import minimize_scalar

from romams_core.structure.dkt import curvature_matrices
from romams_core.structure.modal import build_model, modal_analysis, plate_thickness, solve_modes, thickness_form
from romams_core.structure.plate_mesh import plate_mesh
from romams_core.wing import PlateStructure, WingDefinition, template

YATES_HZ = np.array([9.60, 38.17, 48.35, 91.54, 118.11])  # Yates' calculated modes, weakened model 3
PUBLISHED_G12 = 0.4392e9  # Pa, the equivalent-plate G12 used by most FE models
PSI = 6894.757293168  # Pa


def _with(wing: WingDefinition, **changes: float) -> WingDefinition:
    """Copy of a plate wing with material fields (E1, G12, ...) or structure fields (fe_n_chord, ...) replaced."""
    s = wing.structure
    assert isinstance(s, PlateStructure)
    mat_fields = {f.name for f in dataclasses.fields(s.material)}
    mat = dataclasses.replace(s.material, **{k: v for k, v in changes.items() if k in mat_fields})
    rest = {k: v for k, v in changes.items() if k not in mat_fields}
    return dataclasses.replace(wing, structure=dataclasses.replace(s, material=mat, **rest))


def frequencies(wing: WingDefinition, n_modes: int = 5, root_clamp: tuple[float, float] = (0.0, 1.0)) -> np.ndarray:
    """FE frequencies (Hz); ``root_clamp``: chord-fraction range of root nodes that are clamped (default: all)."""
    model = build_model(wing)
    s = wing.structure
    assert isinstance(s, PlateStructure)
    if root_clamp != (0.0, 1.0):
        xi = np.linspace(0.0, 1.0, s.fe_n_chord + 1)  # root nodes are 0 .. n_chord, equally spaced
        released = np.flatnonzero((xi < root_clamp[0] - 1e-9) | (xi > root_clamp[1] + 1e-9))
        model.free = np.union1d(model.free, (3 * released[:, None] + np.arange(3)).ravel())
    omega, _ = solve_modes(model, n_modes)
    return omega / (2.0 * math.pi)


def relative_to_yates(f: np.ndarray) -> list[float]:
    """Per cent deviation from Yates after scaling mode 1 to 9.60 Hz (what a density re-tune leaves)."""
    g = np.asarray(f)[: YATES_HZ.size] * YATES_HZ[0] / f[0]
    return [round(float(v), 2) for v in 100.0 * (g / YATES_HZ - 1.0)]


def _ritz_setup(wing: WingDefinition, n_xi: int, n_eta: int, n_quad: int) -> dict:
    """Quadrature on the mapped trapezoid (xi split at 5 % chord for the nose), thickness and geometry."""
    pf, s = wing.planform, wing.structure
    assert isinstance(s, PlateStructure)
    g, gw = legendre.leggauss(n_quad)
    xq = np.concatenate([0.05 * (g + 1) / 2, 0.05 + 0.95 * (g + 1) / 2])
    xw = np.concatenate([0.05 * gw / 2, 0.95 * gw / 2])
    eq, ew = (g + 1) / 2, gw / 2
    xi, eta = np.meshgrid(xq, eq, indexing="ij")
    chord = pf.root_chord + (pf.tip_chord - pf.root_chord) * eta
    h = s.thickness_to_chord * chord * np.maximum(thickness_form(s.thickness_form, xi), s.min_thickness_fraction)
    h = h * s.thickness_ratio

    def leg(n: int, x: np.ndarray, d: int) -> np.ndarray:  # d-th derivative of P_0..P_n at x (on [-1, 1])
        rows = []
        for k in range(n + 1):
            c = np.zeros(k + 1)
            c[k] = 1.0
            rows.append(legendre.legval(x, legendre.legder(c, d) if d else c))
        return np.array(rows)

    fx = [leg(n_xi, 2 * xq - 1, d) * 2.0**d for d in range(3)]  # d^d/dxi^d
    pe = [leg(n_eta, 2 * eq - 1, d) * 2.0**d for d in range(3)]  # d^d/deta^d
    b, t = pf.semispan, math.tan(pf.sweep_le)
    cy = (pf.tip_chord - pf.root_chord) / b  # dc/dy
    xi_y = -(t + xi * cy) / chord  # d xi / dy (d xi / dx = 1 / c)
    return dict(xq=xq, eq=eq, weight=np.outer(xw, ew) * chord * b, chord=chord, h=h, fx=fx, pe=pe, b=b, cy=cy,
                xi_y=xi_y, q=s.material.plane_stress_q(), rho=s.material.density)


def kirchhoff_ritz(wing: WingDefinition, n_modes: int = 5, n_xi: int = 8, n_eta: int = 8,
                   n_quad: int = 40) -> np.ndarray:
    """Frequencies (Hz) of a plate wing (no beam, no lumped mass) by Rayleigh-Ritz, Kirchhoff plate, clamped root.

    w = sum a_mn P_m(2 xi - 1) eta^2 P_n(2 eta - 1) on the chord/span fractions (xi, eta); the curvatures
    follow from the exact map x = x_le(y) + xi c(y), y = eta b. Independent of the FE code (no mesh, no
    element), it shares only the material's rotated stiffness and the thickness form.
    """
    r = _ritz_setup(wing, n_xi, n_eta, n_quad)
    eq, pe, fx = r["eq"], r["pe"], r["fx"]
    ge = [eq**2 * pe[0], 2 * eq * pe[0] + eq**2 * pe[1], 2 * pe[0] + 4 * eq * pe[1] + eq**2 * pe[2]]

    def field(dx: int, de: int) -> np.ndarray:  # basis derivative d^dx/dxi^dx d^de/deta^de, [n_basis, n_xi_q, n_eta_q]
        return np.einsum("mi,nj->mnij", fx[dx], ge[de]).reshape(-1, r["xq"].size, eq.size)

    c, b, cy, xi_y = r["chord"], r["b"], r["cy"], r["xi_y"]
    w_x, w_xx, w_ee, w_xe = field(1, 0), field(2, 0), field(0, 2), field(1, 1)
    kxx = w_xx / c**2
    kyy = w_xx * xi_y**2 + 2 * w_xe * xi_y / b + w_ee / b**2 - 2 * w_x * xi_y * cy / c
    kxy = 2 * ((w_xx * xi_y + w_xe / b) / c - w_x * cy / c**2)
    kap = np.stack([kxx, kyy, kxy], axis=1)
    d = (r["h"] ** 3 / 12)[None, None] * r["q"][:, :, None, None]
    k = np.einsum("apij,pqij,bqij->ab", kap, d, kap * r["weight"])
    w0 = field(0, 0)
    m = np.einsum("aij,bij->ab", w0, w0 * (r["rho"] * r["h"] * r["weight"])[None])
    lam = eigh(k, m, eigvals_only=True, subset_by_index=(0, n_modes - 1))
    return np.sqrt(lam) / (2.0 * math.pi)


def mindlin_ritz(wing: WingDefinition, shear_ratio: float, n_modes: int = 5, order: int = 14, n_quad: int = 48,
                 kappa: float = 5.0 / 6.0) -> np.ndarray:
    """Reissner-Mindlin Rayleigh-Ritz frequencies (Hz): transverse shear G13 = G23 = shear_ratio * G12, rotary inertia.

    w, beta_x, beta_y each = sum a_mn P_m(2 xi - 1) eta P_n(2 eta - 1) (all three vanish at the root).
    """
    r = _ritz_setup(wing, order, order, n_quad)
    eq, pe, fx = r["eq"], r["pe"], r["fx"]
    g0, g1 = eq * pe[0], pe[0] + eq * pe[1]
    f00 = np.einsum("mi,nj->mnij", fx[0], g0).reshape(-1, r["xq"].size, eq.size)
    f10 = np.einsum("mi,nj->mnij", fx[1], g0).reshape(f00.shape)
    f01 = np.einsum("mi,nj->mnij", fx[0], g1).reshape(f00.shape)
    c, b, xi_y = r["chord"], r["b"], r["xi_y"]
    dx, dy, z = f10 / c, f10 * xi_y + f01 / b, np.zeros_like(f00)
    # unknowns [w, beta_x, beta_y]: kappa = grad beta, gamma = grad w - beta
    kap = np.stack([np.concatenate([z, dx, z]), np.concatenate([z, z, dy]), np.concatenate([z, dy, dx])], axis=1)
    gam = np.stack([np.concatenate([dx, -f00, z]), np.concatenate([dy, z, -f00])], axis=1)
    s = wing.structure
    assert isinstance(s, PlateStructure)
    phi = 0.5 * math.pi - s.material.orientation
    rot = np.array([[math.cos(phi), math.sin(phi)], [-math.sin(phi), math.cos(phi)]])
    gs = rot.T @ (shear_ratio * s.material.G12 * np.eye(2)) @ rot
    h, wq = r["h"], r["weight"]
    d = (h**3 / 12)[None, None] * r["q"][:, :, None, None]
    sh = (kappa * h)[None, None] * gs[:, :, None, None]
    k = np.einsum("apij,pqij,bqij->ab", kap, d, kap * wq) + np.einsum("apij,pqij,bqij->ab", gam, sh, gam * wq)
    rho = r["rho"]
    w = np.concatenate([f00, z, z])
    bx, by = np.concatenate([z, f00, z]), np.concatenate([z, z, f00])
    m = np.einsum("aij,bij->ab", w, w * (rho * h * wq)[None])
    rot_in = rho * h**3 / 12 * wq
    m += np.einsum("aij,bij->ab", bx, bx * rot_in[None]) + np.einsum("aij,bij->ab", by, by * rot_in[None])
    lam = eigh(k, m, eigvals_only=True, subset_by_index=(0, n_modes - 1))
    return np.sqrt(lam) / (2.0 * math.pi)


def mode_character(wing: WingDefinition, n_modes: int = 5) -> dict[str, list]:
    """Per mode: share of the strain energy in twist about the material axes (D66 kappa_12^2 over the total) and
    sign changes of w along the trailing edge, root to tip (values below 5 % of the edge maximum ignored).

    A bending mode stores its energy mostly in kappa_11 (curvature along E1, the swept spar direction), a
    torsion mode in the twist kappa_12; the trailing-edge node count tells first from second.
    """
    s, pf = wing.structure, wing.planform
    assert isinstance(s, PlateStructure) and s.beam is None
    model = build_model(wing)
    omega, phi = solve_modes(model, n_modes)
    pm = plate_mesh(pf, s.fe_n_chord, s.fe_n_span)
    exy = pm.xy[pm.triangles]
    cen = exy.mean(axis=1)
    h = plate_thickness(pf, s, cen[:, 0], cen[:, 1])
    bmat, area = curvature_matrices(exy)
    dofs = (3 * pm.triangles[:, :, None] + np.arange(3)).reshape(-1, 9)
    mat = s.material
    a1 = np.array([math.sin(mat.orientation), math.cos(mat.orientation)])  # E1 direction in (x, y)
    rot = np.array([a1, [a1[1], -a1[0]]])

    def to_material(e: np.ndarray) -> np.ndarray:  # engineering curvature (xx, yy, 2xy) -> material axes
        t = np.array([[e[0], e[2] / 2], [e[2] / 2, e[1]]])
        tm = rot @ t @ rot.T
        return np.array([tm[0, 0], tm[1, 1], 2 * tm[0, 1]])

    tmat = np.column_stack([to_material(v) for v in np.eye(3)])
    q = mat.plane_stress_q()
    tinv = np.linalg.inv(tmat)
    d_mat = tinv.T @ q @ tinv  # reduced stiffness in the material axes (kappa_x^T Q kappa_x = kappa_m^T d_mat kappa_m)
    wgt = h**3 / 12 * area / 3
    twist, te_changes = [], []
    te_nodes = pm.node(pm.n_chord, np.arange(pm.n_span + 1))
    for k in range(n_modes):
        kap = np.einsum("egij,ej->egi", bmat, phi[dofs, k])
        km = np.einsum("ij,egj->egi", tmat, kap)
        total = np.sum(wgt[:, None] * np.einsum("egi,ij,egj->eg", km, d_mat, km))
        twist.append(float(np.sum(wgt[:, None] * d_mat[2, 2] * km[..., 2] ** 2) / total))
        w = phi[3 * te_nodes, k]
        w = w[np.abs(w) > 0.05 * np.abs(w).max()]
        te_changes.append(int(np.sum(np.diff(np.sign(w)) != 0)))
    return {"frequencies_hz": [float(v) for v in omega / (2.0 * math.pi)], "twist_energy_fraction": twist,
            "trailing_edge_sign_changes": te_changes}


def identify_g12(wing: WingDefinition, lower: float = 0.25e9, upper: float = 0.5e9) -> float:
    """G12 (Pa) minimizing the squared log deviations of modes 2-5 from Yates, mode 1 scaled to 9.60 Hz."""

    def objective(g12: float) -> float:
        f = frequencies(_with(wing, G12=g12))
        return float(np.sum(np.log(f[1:] * YATES_HZ[0] / f[0] / YATES_HZ[1:]) ** 2))

    return float(minimize_scalar(objective, bounds=(lower, upper), method="bounded", options={"xatol": 1e5}).x)


def main() -> None:
    """Run the study and print JSON."""
    w = template("agard-445.6")
    published = _with(w, G12=PUBLISHED_G12, density=378.0)  # the template before the G12 identification
    out: dict[str, object] = {}
    out["mesh_published"] = {f"{nc}x{ns}": [round(float(v), 3) for v in frequencies(_with(published, fe_n_chord=nc,
                                                                                           fe_n_span=ns))]
                             for nc, ns in ((8, 10), (16, 20), (32, 40), (64, 80))}
    out["ritz_kirchhoff_published"] = [round(float(v), 3) for v in kirchhoff_ritz(published)]
    out["ritz_mindlin_published"] = {str(r): [round(float(v), 3) for v in mindlin_ritz(published, r)]
                                     for r in (1e3, 1.0, 0.2)}
    out["floor_published_48x60"] = {str(f): relative_to_yates(frequencies(_with(published, min_thickness_fraction=f,
                                                                                fe_n_chord=48, fe_n_span=60)))
                                    for f in (0.0, 0.02, 0.05)}
    cr, ct, b = w.planform.root_chord, w.planform.tip_chord, w.planform.semispan
    orient = {}
    for frac in (0.0, 0.25, 0.5, 1.0):
        ang = math.atan(math.tan(w.planform.sweep_le) - frac * (cr - ct) / b)
        orient[f"along {frac:.2f} chord line ({math.degrees(ang):.2f} deg)"] = relative_to_yates(
            frequencies(_with(published, orientation=ang)))
    for deg in (0.0, 30.0, 60.0):
        orient[f"{deg:.0f} deg"] = relative_to_yates(frequencies(_with(published, orientation=math.radians(deg))))
    out["orientation_published"] = orient
    out["root_clamp_published_40x40"] = {f"{lo}-{hi}": relative_to_yates(frequencies(
        _with(published, fe_n_chord=40, fe_n_span=40), root_clamp=(lo, hi))) for lo, hi in ((0.1, 0.9), (0.2, 0.8))}
    out["yates_weakened_E_G"] = relative_to_yates(frequencies(_with(published, E1=0.47072e6 * PSI,
                                                                    G12=0.059745e6 * PSI)))
    out["published_relative_to_yates"] = relative_to_yates(frequencies(published))
    out["published_character"] = mode_character(published)
    out["identified_G12_16x20"] = identify_g12(published)
    out["identified_G12_32x40"] = identify_g12(_with(published, fe_n_chord=32, fe_n_span=40))
    r = modal_analysis(w, n_modes=5)
    out["template"] = {"G12": w.structure.material.G12 if isinstance(w.structure, PlateStructure) else None,
                       "frequencies_hz": [round(float(v), 3) for v in r.frequencies_hz],
                       "error_pct": [round(float(v), 2) for v in 100 * (r.frequencies_hz / YATES_HZ - 1)],
                       "mass_kg": round(r.mass_kg, 4), "character": mode_character(w),
                       "ritz_kirchhoff": [round(float(v), 3) for v in kirchhoff_ritz(w)],
                       "mesh": {f"{nc}x{ns}": [round(float(v), 3) for v in frequencies(_with(w, fe_n_chord=nc,
                                                                                             fe_n_span=ns))]
                                for nc, ns in ((8, 10), (32, 40), (64, 80))}}
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
