"""2-D validation of the TSD solver (romams_core.aero.tsd) on span-invariant grids; prints JSON.

Cases (method, numbers and discussion in docs/tsd_2d_validation.md):
- ``naca0012``: NACA 0012, M 0.75, alpha 2 deg, steady, on the default 2-D grid scaled by 0.5 / 1 / 2: CL and
  upper shock position (where Cp rises through Cp*), against the TSFOIL2 example of pyTSFoil; ``naca0012_nlr``
  the same with the "nlr" coefficient set, whose sonic velocity is close to the isentropic critical speed;
- ``naca0012_reference``: the same flow from an independent steady discretization of the same equation
  (``reference_steady_tsd``: vertex-centred, Engquist-Osher, Dirichlet vortex far field, Newton with sparse LU),
  the nlr set's equation (``nlr_equation``), and the TSFOIL equation (Krupp similarity scaling) solved by it on
  TSFOIL's own mesh, which reproduces TSFOIL's
  CL and shows what separates TSFOIL's number from ours;
- ``pitching_64a010``: NACA 64A010 pitching about the quarter chord (AGARD CT6 conditions: M 0.796, mean alpha 0,
  1 deg, k 0.202 on the semichord): first harmonic of lift and moment over the last of 4 cycles, with a flat plate
  at the same conditions and compressible linear theory (DLM root strip of an AR 40 wing) as the baseline.

    python -m benchmarks.validate_tsd_2d [--quick] [--no-reference] [--no-pitching]
"""

from __future__ import annotations

import argparse
import json
import math
import time
from typing import Any

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from romams_core.aero.tsd.coefficients import TsdCoefficients, tsd_coefficients
from romams_core.aero.tsd.flow import TsdFlow
from romams_core.aero.tsd.grid import GridSpec, TsdGrid, airfoil_grid, geometric_faces
from romams_core.structure.modal import naca4_thickness_form, thickness_form

#: pyTSFoil example/TSFOIL2/N0012.out (TSFOIL2, NACA 0012, M 0.75, alpha 2 deg, 81 x 64 mesh, Krupp scaling)
TSFOIL_N0012 = {"cl": 0.530591, "cm": -0.019749, "cp_star": -0.603170, "x_shock_range": (0.535006, 0.557751),
                "x_sonic": 0.547, "source": "github.com/swayli94/pyTSFoil example/TSFOIL2/N0012.out (final mesh)"}
#: the default 2-D grid of the validation (airfoil_grid's default): 50 uniform chord cells, boundaries at 20 chords
BASE_SPEC = GridSpec(n_chord=50, cluster=0.0, n_upstream=24, n_downstream=24, x_upstream=20.0, x_downstream=20.0,
                     n_z=34, dz0=0.02, z_max=20.0)
#: TSFOIL2's final mesh for N0012 (x, and y >= 0 in chords; the mesh is symmetric in y), from N0012.out
TSFOIL_X = np.array([
    -4.759090, -1.451373, -1.154130, -0.959227, -0.798421, -0.644242, -0.473078, -0.290925, -0.176356, -0.113082,
    -0.074485, -0.049489, -0.032465, -0.020228, -0.010907, -0.003416, 0.002981, 0.008679, 0.014039, 0.019292,
    0.024707, 0.030523, 0.037083, 0.044772, 0.054190, 0.066066, 0.081200, 0.100083, 0.122447, 0.147263, 0.173324,
    0.199723, 0.225942, 0.251747, 0.277060, 0.301889, 0.326276, 0.350282, 0.373966, 0.397389, 0.420605, 0.443660,
    0.466597, 0.489449, 0.512245, 0.535006, 0.557751, 0.580493, 0.603241, 0.626005, 0.648791, 0.671609, 0.694470,
    0.717388, 0.740383, 0.763482, 0.786719, 0.810138, 0.833793, 0.857753, 0.882101, 0.906941, 0.932402, 0.958646,
    0.985879, 1.014370, 1.044481, 1.076713, 1.111798, 1.150867, 1.195818, 1.250238, 1.322245, 1.436261, 1.647911,
    1.849817, 2.013718, 2.177861, 2.372788, 2.664829, 4.821552])
TSFOIL_Y = np.array([
    0.011800, 0.023653, 0.035615, 0.047741, 0.060093, 0.072733, 0.085732, 0.099167, 0.113124, 0.127701, 0.143013,
    0.159191, 0.176391, 0.194798, 0.214639, 0.236187, 0.259787, 0.285868, 0.314984, 0.347855, 0.385438, 0.429040,
    0.480483, 0.542401, 0.618740, 0.715700, 0.843610, 1.021059, 1.285221, 1.722835, 2.594099, 5.200000])
#: AGARD CT6 (Davis, AGARD-R-702): NACA 64A010 pitching about x/c = 0.25, mean alpha 0, M 0.796, k 0.202 (semichord)
CT6 = {"mach": 0.796, "alpha_mean_deg": 0.0, "alpha_amp_deg": 1.0, "k": 0.202, "x_pivot": 0.25, "t_c": 0.0999}


# ----------------------------------------------------------------------------------------------------- TSD runs
def section_flow(grid: TsdGrid, coef: TsdCoefficients, form: str | None, t_c: float) -> tuple[TsdFlow, np.ndarray]:
    """A flow on a 2-D grid and the section's half-thickness slope per chord cell (exact cell average)."""
    flow = TsdFlow(grid, coef)
    slope = np.zeros(grid.xc.size)
    if form is not None and t_c > 0.0:
        xf = np.clip(grid.xf, 0.0, 1.0)
        with np.errstate(invalid="ignore", divide="ignore"):
            slope = np.nan_to_num(0.5 * t_c * np.diff(thickness_form(form, xf)) / np.diff(grid.xf))
    return flow, slope


def set_motion(flow: TsdFlow, slope: np.ndarray, alpha: float, alpha_dot: float = 0.0, x_pivot: float = 0.25) -> None:
    """Slit conditions of a section at incidence alpha (rad), pitching at alpha_dot (rad per t*) about x_pivot."""
    g = flow.grid
    w = -alpha - alpha_dot * (g.xc - x_pivot)
    flow.w_up[:] = np.where(g.wing, (w + slope)[:, None], 0.0)
    flow.w_lo[:] = np.where(g.wing, (w - slope)[:, None], 0.0)


def upper_shock(x: np.ndarray, cp: np.ndarray, cp_star: float) -> float:
    """Chord position where the upper-surface Cp rises through Cp* (the last such crossing; nan if none)."""
    xs = math.nan
    for i in range(x.size - 1):
        if cp[i] < cp_star <= cp[i + 1]:
            xs = float(x[i] + (cp_star - cp[i]) / (cp[i + 1] - cp[i]) * (x[i + 1] - x[i]))
    return xs


def steady_section(spec: GridSpec, mach: float, alpha_deg: float, form: str | None, t_c: float, dt: float,
                   coefficients: str = "ames", max_steps: int = 40000, tol: float = 1e-5) -> dict[str, Any]:
    """Steady 2-D TSD solution: CL (lift from the potential jump), CM about c/4, upper shock, convergence."""
    g = airfoil_grid(spec)
    coef = tsd_coefficients(mach, coefficients)
    flow, slope = section_flow(g, coef, form, t_c)
    set_motion(flow, slope, math.radians(alpha_deg))
    res = flow.solve_steady(dt=dt, max_steps=max_steps, tol=tol)
    lift = flow.cell_lift()[:, 0]
    up, lo = flow.surface_cp()
    w = g.wing[:, 0]
    return {"n_chord": spec.n_chord, "n_points": g.n_points, "dz0": spec.dz0, "dt": dt,
            "cl": float(lift.sum()), "cm_quarter": float(-(lift * (g.xc - 0.25)).sum()),
            "x_shock": upper_shock(g.xc[w], up[w, 0], coef.cp_star), "cp_star": coef.cp_star,
            "steps": res.steps, "converged": res.converged, "seconds": round(res.seconds, 2),
            "_flow": flow}


def isentropic_cp_star(mach: float, gamma: float = 1.4) -> float:
    """Exact critical pressure coefficient of isentropic flow at free-stream ``mach`` (dimensionless)."""
    ratio = (2.0 + (gamma - 1.0) * mach ** 2) / (gamma + 1.0)
    return 2.0 / (gamma * mach ** 2) * (ratio ** (gamma / (gamma - 1.0)) - 1.0)


def naca0012_table(scales: tuple[float, ...], coefficients: str = "ames") -> list[dict[str, Any]]:
    """NACA 0012, M 0.75, alpha 2 deg on the base grid scaled by each factor (dt scales with the cells; the step
    budget too: the nlr set's 100-cell march needs 41,585 steps)."""
    rows = []
    for s in scales:
        row = steady_section(BASE_SPEC.scaled(s), 0.75, 2.0, "naca4", 0.12, dt=0.02 / s, coefficients=coefficients,
                             max_steps=int(40000 * max(1.0, s)))
        row.pop("_flow")
        rows.append({"scale": s, **row})
    return rows


# ------------------------------------------------------------------------- independent steady reference solver
def reference_steady_tsd(x: np.ndarray, z: np.ndarray, E: float, F: float, slope_up: np.ndarray,
                         slope_lo: np.ndarray, tol: float = 1e-10, max_iter: int = 100) -> dict[str, Any]:
    """Steady 2-D TSD, E phi_xx + F (phi_x^2)_x + phi_zz = 0, discretized independently of the AF kernels.

    Vertex-centred finite differences on the nodes x[i], z[j] (z symmetric, no node on z = 0): conservative
    Engquist-Osher streamwise flux on the half points, the slit conditions phi_z = slope_up / slope_lo at z = 0+/0-
    for 0 < x < 1 (half control volumes next to the slit), the jump Gamma across z = 0 behind the airfoil, Kutta by
    linear extrapolation of phi to z = 0+/0- at the last airfoil node (as TSFOIL does), and phi prescribed on the
    outer nodes as the compressible vortex at x = 1/4. Solved by Newton with pseudo-transient continuation and
    sparse LU. Returns CL = 2 Gamma, the circulation and the potential.
    """
    ni, nj = x.size, z.size
    jl = nj // 2 - 1
    ju = jl + 1
    air = (x > 0.0) & (x < 1.0)
    wake = x > 1.0
    ite = int(np.flatnonzero(air)[-1])
    n = ni * nj
    beta = math.sqrt(E)
    u_star = -E / (2.0 * F)
    g_star = E * u_star + F * u_star ** 2
    ids = np.arange(n).reshape(ni, nj)
    dxh = np.diff(x)
    dzh = np.diff(z)
    dxc = np.zeros(ni)
    dxc[1:-1] = 0.5 * (x[2:] - x[:-2])
    dzc = np.zeros((ni, nj))
    dzc[:, 1:-1] = 0.5 * (z[2:] - z[:-2])[None, :]
    dzc[air, ju] = 0.5 * (z[ju] + z[ju + 1])  # half control volumes on the slit
    dzc[air, jl] = -0.5 * (z[jl] + z[jl - 1])
    xx, zz = np.meshgrid(x, z, indexing="ij")
    vortex = np.arctan2(beta * zz, -(xx - 0.25)) / (2.0 * math.pi)  # per unit circulation
    outer = np.ones((ni, nj), bool)
    outer[1:-1, 1:-1] = False
    inner = ~outer
    w1, w2 = z[ju + 1] / (z[ju + 1] - z[ju]), -z[ju] / (z[ju + 1] - z[ju])
    l1, l2 = z[jl - 1] / (z[jl - 1] - z[jl]), -z[jl] / (z[jl - 1] - z[jl])

    def residual_jacobian(y: np.ndarray) -> tuple[np.ndarray, sp.csr_matrix]:
        p = y[:n].reshape(ni, nj)
        gam = y[n]
        rows: list[np.ndarray] = []
        cols: list[np.ndarray] = []
        vals: list[np.ndarray] = []

        def add(r: np.ndarray, c: np.ndarray, v: np.ndarray) -> None:
            r, c, v = np.broadcast_arrays(r, c, v)
            rows.append(r.ravel())
            cols.append(c.ravel())
            vals.append(v.ravel())

        res = np.zeros((ni, nj))
        # streamwise EO fluxes on the half points i+1/2 (i = 0 .. ni-2)
        u = np.diff(p, axis=0) / dxh[:, None]
        gp = E * np.minimum(u, u_star) + F * np.minimum(u, u_star) ** 2
        gm = E * np.maximum(u, u_star) + F * np.maximum(u, u_star) ** 2 - g_star
        dgp = np.where(u < u_star, E + 2.0 * F * u, 0.0) / dxh[:, None]
        dgm = np.where(u >= u_star, E + 2.0 * F * u, 0.0) / dxh[:, None]
        i = np.arange(1, ni - 1)[:, None]
        j = np.arange(1, nj - 1)[None, :]
        a = 1.0 / dxc[i]
        gm2 = np.where(i >= 2, gm[np.maximum(i - 2, 0), j], 0.0)  # gm at i-3/2, zero ahead of the first face
        res[i, j] += a * (gp[i, j] - gp[i - 1, j] + gm[i - 1, j] - gm2)
        add(ids[i, j], ids[i + 1, j], a * dgp[i, j])
        add(ids[i, j], ids[i, j], -a * (dgp[i, j] + dgp[i - 1, j] - dgm[i - 1, j]))
        add(ids[i, j], ids[i - 1, j], a * (dgp[i - 1, j] - dgm[i - 1, j]))
        k = np.arange(2, ni - 1)[:, None]
        ak = 1.0 / dxc[k]
        add(ids[k, j], ids[k - 1, j], -ak * dgm[k - 2, j])
        add(ids[k, j], ids[k - 2, j], ak * dgm[k - 2, j])
        # normal fluxes on the half points j+1/2; the slit and wake replace the one between jl and ju
        for j in range(1, nj - 1):
            for jh, sgn in ((j, 1.0), (j - 1, -1.0)):  # top face (+), bottom face (-) of node j
                rj = ids[1:-1, j]
                h = dzc[1:-1, j]
                if jh == jl:
                    on_air = air[1:-1]
                    slit = slope_lo[1:-1] if j == jl else slope_up[1:-1]
                    flux = (p[1:-1, ju] - p[1:-1, jl] - gam * wake[1:-1]) / dzh[jl]
                    res[1:-1, j] += sgn * np.where(on_air, slit, flux) / h
                    off = ~on_air
                    add(rj[off], ids[1:-1, ju][off], sgn / (dzh[jl] * h[off]))
                    add(rj[off], ids[1:-1, jl][off], -sgn / (dzh[jl] * h[off]))
                    wk = wake[1:-1]
                    add(rj[wk], np.full(wk.sum(), n), -sgn / (dzh[jl] * h[wk]))
                else:
                    res[1:-1, j] += sgn * (p[1:-1, jh + 1] - p[1:-1, jh]) / dzh[jh] / h
                    add(rj, ids[1:-1, jh + 1], sgn / (dzh[jh] * h))
                    add(rj, ids[1:-1, jh], -sgn / (dzh[jh] * h))
        # far field: phi = Gamma * vortex on the outer nodes
        res[outer] = p[outer] - gam * vortex[outer]
        add(ids[outer], ids[outer], np.ones(outer.sum()))
        add(ids[outer], np.full(outer.sum(), n), -vortex[outer])
        # Kutta: Gamma = jump of phi extrapolated to z = 0+/0- at the last airfoil node
        rk = gam - (w1 * p[ite, ju] + w2 * p[ite, ju + 1] - l1 * p[ite, jl] - l2 * p[ite, jl - 1])
        add(np.full(5, n), np.array([n, ids[ite, ju], ids[ite, ju + 1], ids[ite, jl], ids[ite, jl - 1]]),
            np.array([1.0, -w1, -w2, l1, l2]))
        jac = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n + 1, n + 1))
        return np.concatenate((res.ravel(), [rk])), jac

    y = np.zeros(n + 1)
    ptc = np.concatenate((inner.ravel().astype(float), [0.0]))
    dtau = 1e-2
    rnorm = math.inf
    it = 0
    for it in range(max_iter):  # noqa: B007 - the count is returned
        res, jac = residual_jacobian(y)
        rnorm = float(np.abs(res).max())
        if rnorm < tol:
            break
        y += spla.spsolve((jac - sp.diags(ptc / dtau)).tocsc(), -res)
        dtau = min(2.0 * dtau, 1e12)
    p = y[:n].reshape(ni, nj)
    return {"cl": 2.0 * float(y[n]), "gamma": float(y[n]), "residual": rnorm, "iterations": it, "phi": p,
            "jl": jl, "ju": ju, "air": air}


def uniform_reference_grid(n_chord: int, n_far: int, n_z: int, dz0: float, far: float = 20.0) -> tuple[np.ndarray,
                                                                                                       np.ndarray]:
    """Nodes of the reference solver: uniform on the chord (first node half a cell behind the LE), stretched out."""
    h = 1.0 / n_chord
    out = geometric_faces(h, far, n_far)[1:] - 0.5 * h
    x = np.concatenate((-out[::-1], (np.arange(n_chord) + 0.5) * h, 1.0 + out))
    zp = 0.5 * dz0 + geometric_faces(dz0, far, n_z)[:-1]
    return x, np.concatenate((-zp[::-1], zp))


def reference_naca0012(n_chord: int = 50, n_far: int = 24, n_z: int = 34, dz0: float = 0.02,
                       F: float | None = None, slope_scale: float = 1.0, alpha_deg: float = 2.0) -> dict[str, Any]:
    """NACA 0012 at M 0.75 by the reference solver on a uniform chord grid (cell-averaged slopes); F defaults to the
    Ames/2-D value -1.2 M^2, slope_scale multiplies thickness and incidence slopes (Krupp's scaling: M^-0.25)."""
    m = 0.75
    E = 1.0 - m * m
    F = tsd_coefficients(m, "ames").F if F is None else F
    x, z = uniform_reference_grid(n_chord, n_far, n_z, dz0)
    h = 1.0 / n_chord
    air = (x > 0) & (x < 1)
    tf = naca4_thickness_form(np.clip(np.stack((x - 0.5 * h, x + 0.5 * h)), 0.0, 1.0))
    th = np.where(air, 0.06 * (tf[1] - tf[0]) / h, 0.0)
    a = math.radians(alpha_deg)
    t0 = time.perf_counter()
    out = reference_steady_tsd(x, z, E, F, slope_scale * (th - a), slope_scale * (-th - a))
    p, ju = out.pop("phi"), out["ju"]
    cp = -2.0 * np.gradient(p[:, ju], x)
    out["x_shock"] = upper_shock(x[air], cp[air], 2.0 * E / (2.0 * F))
    out.update(n_chord=n_chord, n_points=x.size * z.size, alpha_deg=alpha_deg,
               seconds=round(time.perf_counter() - t0, 2))
    for key in ("jl", "ju", "air"):
        out.pop(key)
    return out


def reference_on_tsfoil_mesh() -> dict[str, Any]:
    """TSFOIL's equation on TSFOIL's mesh, by the reference solver: Krupp's similarity scaling (SIMDEF 3) in chord
    units is the TSD equation with F = -(gamma+1) M^1.75 / 2 and the slopes multiplied by M^-0.25 (Cp = -2 phi_x),
    and TSFOIL takes the body slopes at the mesh points (here the analytic NACA 0012 slope)."""
    m = 0.75
    E = 1.0 - m * m
    F = -0.5 * 2.4 * m ** 1.75
    x = TSFOIL_X
    z = np.concatenate((-TSFOIL_Y[::-1], TSFOIL_Y))
    air = (x > 0) & (x < 1)
    xa = np.where(air, x, 0.5)
    th = np.where(air, 0.6 * (0.14845 / np.sqrt(xa) - 0.126 - 0.7032 * xa + 0.8529 * xa ** 2 - 0.406 * xa ** 3), 0.0)
    a = math.radians(2.0)
    s = m ** -0.25
    t0 = time.perf_counter()
    out = reference_steady_tsd(x, z, E, F, s * (th - a), s * (-th - a))
    p, ju = out.pop("phi"), out["ju"]
    cp = -2.0 * np.gradient(p[:, ju], x)
    cp_star = -2.0 * (-E / (2.0 * F))
    return {"equation": "Krupp scaling: F = -1.2 M^1.75, slopes x M^-0.25", "cl": out["cl"],
            "x_shock": upper_shock(x[air], cp[air], cp_star), "cp_star": cp_star, "residual": out["residual"],
            "seconds": round(time.perf_counter() - t0, 2), "tsfoil": {k: TSFOIL_N0012[k] for k in ("cl", "x_sonic")}}


# ---------------------------------------------------------------------------------------------- pitching CT6
def pitching_section(form: str | None, t_c: float, spec: GridSpec = BASE_SPEC, cycles: int = 4,
                     steps_per_cycle: int = 800, coefficients: str = "ames") -> dict[str, Any]:
    """First harmonic of CL and CM (about the pivot, nose up) per radian of pitch, CT6 conditions, last cycle."""
    g = airfoil_grid(spec)
    coef = tsd_coefficients(CT6["mach"], coefficients)
    flow, slope = section_flow(g, coef, form, t_c)
    xp = CT6["x_pivot"]
    set_motion(flow, slope, math.radians(CT6["alpha_mean_deg"]))
    t0 = time.perf_counter()
    steady = flow.solve_steady(dt=0.02, max_steps=20000, tol=1e-5)
    omega = 2.0 * CT6["k"]  # per unit t* = t U / c
    period = 2.0 * math.pi / omega
    dt = period / steps_per_cycle
    amp = math.radians(CT6["alpha_amp_deg"])
    cl0 = float(flow.cell_lift()[:, 0].sum())
    t_hist, cl, cm = [], [], []
    for n in range(1, cycles * steps_per_cycle + 1):
        t = n * dt
        set_motion(flow, slope, math.radians(CT6["alpha_mean_deg"]) + amp * math.sin(omega * t),
                   amp * omega * math.cos(omega * t), xp)
        flow.step(dt)
        lift = flow.cell_lift(dt)[:, 0]
        t_hist.append(t)
        cl.append(float(lift.sum()))
        cm.append(float(-(lift * (g.xc - xp)).sum()))
    last = slice((cycles - 1) * steps_per_cycle, cycles * steps_per_cycle)
    tt = np.asarray(t_hist)[last]

    def harmonic(sig: list[float]) -> complex:
        s = np.asarray(sig)[last]
        return complex(2.0 / steps_per_cycle * np.sum(s * np.sin(omega * tt)),
                       2.0 / steps_per_cycle * np.sum(s * np.cos(omega * tt))) / amp

    cla, cma = harmonic(cl), harmonic(cm)
    return {"section": form or "flat plate", "t_c": t_c, "cl_mean": cl0, "steady_steps": steady.steps,
            "cl_alpha": [cla.real, cla.imag], "cl_alpha_mag": abs(cla),
            "cl_alpha_phase_deg": math.degrees(np.angle(cla)), "cm_alpha": [cma.real, cma.imag],
            "cm_alpha_mag": abs(cma), "cm_alpha_phase_deg": math.degrees(np.angle(cma)), "dt": dt,
            "seconds": round(time.perf_counter() - t0, 1)}


def dlm_strip(mach: float, k: float, x_pivot: float) -> dict[str, Any]:
    """Compressible linear theory for a flat plate pitching about x_pivot: root strip of a rectangular AR 40 wing
    by the doublet-lattice method (24 x 32 boxes, span stations eta^2; the recipe of tests/test_dlm.py, which is
    within 1-3 % and 2 deg of Theodorsen at M = 0). Lift and moment (nose up, about x_pivot) per radian."""
    from romams_core.aero import dlm
    from romams_core.mesh import Planform, StandardMesh, standard_mesh

    nc, ns = 24, 32
    pf = Planform(root_chord=1.0, tip_chord=1.0, semispan=20.0, n_chord=nc, n_span=ns)
    xi, eta = np.meshgrid(np.linspace(0.0, 1.0, nc + 1), np.linspace(0.0, 1.0, ns + 1) ** 2.0)
    px, py = pf.to_xy(xi.ravel(), eta.ravel())
    mesh = StandardMesh(planform=pf, x=px, y=py, panels=standard_mesh(pf).panels)
    system = dlm.build_dlm(mesh, mach)
    cp = system.pressures(-(mesh.x - x_pivot)[:, None], np.array([k]))
    root = np.arange(nc)
    dy = mesh.y[nc + 1] - mesh.y[0]
    load = cp[0, root, 0] * system.area[root] / dy  # section lift per box over q c (chord 1)
    arm = system.grid["offset_l"][root, 0] * system.grid["unit"] - x_pivot
    cla, cma = complex(load.sum()), complex(-(load * arm).sum())
    return {"method": "DLM root strip, AR 40", "cl_alpha": [cla.real, cla.imag], "cl_alpha_mag": abs(cla),
            "cl_alpha_phase_deg": math.degrees(np.angle(cla)), "cm_alpha": [cma.real, cma.imag],
            "cm_alpha_mag": abs(cma), "cm_alpha_phase_deg": math.degrees(np.angle(cma))}


def pitching_64a010(cycles: int = 4) -> dict[str, Any]:
    """CT6 conditions: TSD NACA 64A010 and flat plate, and linear theory."""
    return {"conditions": CT6,
            "reference": ("no published CT6 harmonic (experiment or TSD/Euler) could be retrieved from the available "
                          "sources; linear theory (DLM) is the baseline"),
            "tsd_64a010": pitching_section("naca64a010", CT6["t_c"], cycles=cycles),
            "tsd_flat_plate": pitching_section(None, 0.0, cycles=cycles),
            "linear_theory": dlm_strip(CT6["mach"], CT6["k"], CT6["x_pivot"])}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="grids 0.5 and 1 only (no 2x grid)")
    ap.add_argument("--no-reference", action="store_true", help="skip the independent reference solver")
    ap.add_argument("--no-pitching", action="store_true", help="skip the CT6 pitching case")
    args = ap.parse_args()
    scales = (0.5, 1.0) if args.quick else (0.5, 1.0, 2.0)
    out: dict[str, Any] = {"tsfoil": TSFOIL_N0012, "isentropic_cp_star": isentropic_cp_star(0.75),
                           "naca0012": naca0012_table(scales), "naca0012_nlr": naca0012_table(scales, "nlr")}
    if not args.no_reference:
        grids = ((50, 24, 34, 0.02), (100, 30, 40, 0.01), (200, 40, 50, 0.005))
        f_krupp, s_krupp = -0.5 * 2.4 * 0.75 ** 1.75, 0.75 ** -0.25
        out["naca0012_reference"] = {
            "same_equation": [reference_naca0012(*gr) for gr in grids],
            "nlr_equation": [reference_naca0012(*gr, F=tsd_coefficients(0.75, "nlr").F) for gr in grids],
            "tsfoil_equation_uniform_grids": [reference_naca0012(*gr, F=f_krupp, slope_scale=s_krupp)
                                              for gr in grids[:2]],
            "tsfoil_equation_on_tsfoil_mesh": reference_on_tsfoil_mesh(),
            "lift_curve_50_cells": {
                "alpha_deg": [1.0, 1.5, 2.0, 2.5],
                "cl_ames": [reference_naca0012(alpha_deg=a)["cl"] for a in (1.0, 1.5, 2.0, 2.5)],
                "cl_krupp": [reference_naca0012(F=f_krupp, slope_scale=s_krupp, alpha_deg=a)["cl"]
                             for a in (1.0, 1.5, 2.0, 2.5)]}}
    if not args.no_pitching:
        out["pitching_64a010"] = pitching_64a010()
    print(json.dumps(out, indent=2, default=float))


if __name__ == "__main__":
    main()
