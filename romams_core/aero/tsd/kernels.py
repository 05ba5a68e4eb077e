"""Numba kernels of the TSD scheme: the conservative residual and the three approximate-factorization line solves.

Arrays are phi[i, j, k] (xi, y, z nodes), each node the centre of a finite-volume cell. Every node carries
N(phi) = -A c phi_tt - B (phi_xi)_t + D_xi F1 + D_eta F2 + D_zeta F3, the flux differences over its cell faces.
The outer faces carry the far-field conditions as fluxes (first-order non-reflecting, tsd-notes section 3):
phi_x = -kappa phi_t upstream and downstream, phi_z = -/+ kappa_z phi_t at the bottom / top, phi_y = -kappa_y phi_t
at the lateral boundary (3-D). The root face y = 0 (``root``, the grid's ROOT_CODES) is a symmetry plane (0: phi
mirrored, zero flux), an antisymmetry plane (1: phi mirrored with the opposite sign, so phi = 0 on it and the
flux is c phi / y of the first node) or, for a free wing (2), the grid continues to y < 0 and its first y face
is a lateral far field too, phi_y = +kappa_y phi_t. With kappa = 0 (steady) they are zero-gradient conditions.

The right-hand side of the factored Newton step is s N (s = dt^2 / (A c a0), so that each factor has a unit
diagonal from the time terms); each factor carries the linearized fluxes of its own direction, boundary faces
included. phi_xt is differenced upwind (backward), which keeps the pseudo-time and wake coupling stable.

Time derivatives use generic backward formulas on four levels (new, n, n-1, n-2):
phi_tt = (a0 phi + a1 phi_n + a2 phi_n1 + a3 phi_n2) / dt^2, phi_t = (b0 phi + b1 phi_n + b2 phi_n1) / dt.

``tc`` = [a0, a1, a2, a3, b0, b1, b2, dt, kappa_upstream, kappa_downstream, kappa_z, kappa_y];
``co`` = [A, B, E, F, G, H, u_star].
"""

from __future__ import annotations

import numba as nb
import numpy as np


@nb.njit(cache=True, inline="always")
def _g(u: float, e: float, f: float) -> float:
    return e * u + f * u * u


@nb.njit(cache=True, nogil=True)
def _central_xi(phi: np.ndarray, xc: np.ndarray) -> np.ndarray:
    """d(phi)/d(xi) at the nodes: central inside, one-sided at the ends."""
    ni, nj, nk = phi.shape
    out = np.empty_like(phi)
    for i in range(ni):
        lo = max(i - 1, 0)
        hi = min(i + 1, ni - 1)
        inv = 1.0 / (xc[hi] - xc[lo])
        for j in range(nj):
            for k in range(nk):
                out[i, j, k] = (phi[hi, j, k] - phi[lo, j, k]) * inv
    return out


@nb.njit(cache=True, nogil=True)
def _upwind_xi(phi: np.ndarray, xc: np.ndarray) -> np.ndarray:
    """d(phi)/d(xi) at the nodes by the backward (upwind) difference; zero at the first node."""
    ni, nj, nk = phi.shape
    out = np.zeros_like(phi)
    for i in range(1, ni):
        inv = 1.0 / (xc[i] - xc[i - 1])
        for j in range(nj):
            for k in range(nk):
                out[i, j, k] = (phi[i, j, k] - phi[i - 1, j, k]) * inv
    return out


@nb.njit(cache=True, nogil=True)
def _central_eta(phi: np.ndarray, yc: np.ndarray, root: int) -> np.ndarray:
    """d(phi)/dy at the nodes: central inside, one-sided at the far end; at the root mirrored (``root`` 0, the
    ghost node -yc[0] carries phi), mirrored with the opposite sign (1: -phi) or one-sided (2: a free wing)."""
    ni, nj, nk = phi.shape
    out = np.zeros_like(phi)
    if nj == 1:
        return out
    for j in range(nj):
        odd = False
        if j == 0 and root == 2:
            ylo, jlo = yc[0], 0
        elif j == 0:
            ylo, jlo = -yc[0], 0
            odd = root == 1
        else:
            ylo, jlo = yc[j - 1], j - 1
        jhi = min(j + 1, nj - 1)
        yhi = yc[jhi]
        if j == nj - 1:
            ylo, jlo = yc[j - 1], j - 1
            yhi, jhi = yc[j], j
        inv = 1.0 / (yhi - ylo)
        for i in range(ni):
            for k in range(nk):
                if odd:
                    out[i, j, k] = (phi[i, jhi, k] + phi[i, jlo, k]) * inv
                else:
                    out[i, j, k] = (phi[i, jhi, k] - phi[i, jlo, k]) * inv
    return out


@nb.njit(cache=True, nogil=True)
def residual(phi, p1, p2, p3, tc, co, xc, xf, yc, yf, zc, zf, cj, cyf, xiy_xf, xiy_yf,
             wing, wake, wup, wlo, gam, k0, lateral_far, root, c_root, far_u, far_w, sponge,
             rhs):  # pragma: no cover - compiled
    """Fill ``rhs`` (the factored-step right-hand side s N) and return (max |N|, rms N) over all nodes.

    ``root``: the root face's condition (module docstring); ``c_root``: the chord there (c_ref units).
    ``far_u`` [2, nj, nk] and ``far_w`` [2, ni, nj]: prescribed far-field phi_x on the upstream/downstream faces
    and phi_z on the bottom/top faces, added to the non-reflecting conditions (a 2-D vortex far field; zero in 3-D).
    ``sponge`` [ni, nj, nk]: damping rate sigma (1/t*) of the absorbing layer, N -= A c sigma phi_t (zero inside).
    """
    ni, nj, nk = phi.shape
    a0, a1, a2, a3, b0, b1, b2, dt = tc[0], tc[1], tc[2], tc[3], tc[4], tc[5], tc[6], tc[7]
    ku, kd, kz, ky = tc[8], tc[9], tc[10], tc[11]
    A, B, E, F, G, H, us = co[0], co[1], co[2], co[3], co[4], co[5], co[6]
    gus = _g(us, E, F)
    three_d = nj > 1
    px = _central_xi(phi, xc)
    pe = _central_eta(phi, yc, root)
    ux = _upwind_xi(phi, xc)
    ux1 = _upwind_xi(p1, xc)
    ux2 = _upwind_xi(p2, xc)
    jmax = np.zeros(nj)
    jsum = np.zeros(nj)
    for j in range(nj):
        gp = np.empty(ni + 1)
        gm = np.zeros(ni + 1)
        xx = np.zeros(ni + 1)
        f3 = np.empty(nk + 1)
        nmax = 0.0
        nsum = 0.0
        c = cj[j]
        dyj = yf[j + 1] - yf[j]
        for k in range(nk):
            # streamwise fluxes on faces 0..ni (face f is left of node f); outer faces from the far-field condition
            for f in range(1, ni):
                dxf = xc[f] - xc[f - 1]
                phxi = (phi[f, j, k] - phi[f - 1, j, k]) / dxf
                u = phxi / c
                gp[f] = _g(min(u, us), E, F)
                gm[f] = _g(max(u, us), E, F) - gus
                if three_d:
                    xy = xiy_xf[f - 1, j]
                    py = 0.5 * (pe[f - 1, j, k] + pe[f, j, k]) + xy * phxi
                    xx[f] = G * py * py + c * xy * (py + H * u * py)
            pt0 = (b0 * phi[0, j, k] + b1 * p1[0, j, k] + b2 * p2[0, j, k]) / dt
            ptn = (b0 * phi[ni - 1, j, k] + b1 * p1[ni - 1, j, k] + b2 * p2[ni - 1, j, k]) / dt
            gp[0] = _g(far_u[0, j, k] - ku * pt0, E, F)
            gp[ni] = _g(far_u[1, j, k] - kd * ptn, E, F)
            for i in range(ni):
                ptt = (a0 * phi[i, j, k] + a1 * p1[i, j, k] + a2 * p2[i, j, k] + a3 * p3[i, j, k]) / (dt * dt)
                pxt = (b0 * ux[i, j, k] + b1 * ux1[i, j, k] + b2 * ux2[i, j, k]) / dt
                gmm = gm[i - 1] if i >= 1 else 0.0
                dxi = (gp[i + 1] - gp[i] + gm[i] - gmm + xx[i + 1] - xx[i]) / (xf[i + 1] - xf[i])
                pt = (b0 * phi[i, j, k] + b1 * p1[i, j, k] + b2 * p2[i, j, k]) / dt
                rhs[i, j, k] = -A * c * (ptt + sponge[i, j, k] * pt) - B * pxt + dxi
        # spanwise fluxes (3-D): root face by ``root``, outer face from the lateral far-field condition
        if three_d:
            for i in range(ni):
                for k in range(nk):
                    if j < nj - 1:
                        dy = yc[j + 1] - yc[j]
                        pxi = 0.5 * (px[i, j, k] + px[i, j + 1, k])
                        py = (phi[i, j + 1, k] - phi[i, j, k]) / dy + xiy_yf[i, j] * pxi
                        fr = cyf[j] * (py + H * (pxi / cyf[j]) * py)
                    elif lateral_far:
                        pt = (b0 * phi[i, j, k] + b1 * p1[i, j, k] + b2 * p2[i, j, k]) / dt
                        fr = -c * ky * pt
                    else:
                        fr = 0.0
                    fl = 0.0
                    if j > 0:
                        dy = yc[j] - yc[j - 1]
                        pxi = 0.5 * (px[i, j - 1, k] + px[i, j, k])
                        py = (phi[i, j, k] - phi[i, j - 1, k]) / dy + xiy_yf[i, j - 1] * pxi
                        fl = cyf[j - 1] * (py + H * (pxi / cyf[j - 1]) * py)
                    elif root == 1:  # ghost -phi at -yc[0]: phi = 0 and phi_xi = 0 on the plane (u = 0 there)
                        fl = c_root * (phi[i, 0, k] + phi[i, 0, k]) / (yc[0] + yc[0])
                    elif root == 2:  # free wing: lateral far field below the root, phi_y = +kappa_y phi_t
                        pt = (b0 * phi[i, j, k] + b1 * p1[i, j, k] + b2 * p2[i, j, k]) / dt
                        fl = c * ky * pt
                    rhs[i, j, k] += (fr - fl) / dyj
        # normal fluxes (face f below node f), the slit condition on the planform and the jump in the wake
        for i in range(ni):
            for f in range(1, nk):
                f3[f] = c * (phi[i, j, f] - phi[i, j, f - 1]) / (zc[f] - zc[f - 1])
            f3[0] = c * (far_w[0, i, j] + kz * (b0 * phi[i, j, 0] + b1 * p1[i, j, 0] + b2 * p2[i, j, 0]) / dt)
            f3[nk] = c * (far_w[1, i, j] - kz * (b0 * phi[i, j, nk - 1] + b1 * p1[i, j, nk - 1]
                                                 + b2 * p2[i, j, nk - 1]) / dt)
            if wake[i, j]:
                f3[k0 + 1] -= c * gam[i, j] / (zc[k0 + 1] - zc[k0])
            for k in range(nk):
                top = f3[k + 1]
                bot = f3[k]
                if wing[i, j]:
                    if k == k0:
                        top = c * wlo[i, j]
                    elif k == k0 + 1:
                        bot = c * wup[i, j]
                n = rhs[i, j, k] + (top - bot) / (zf[k + 1] - zf[k])
                aval = abs(n)
                if aval > nmax:
                    nmax = aval
                nsum += n * n
                rhs[i, j, k] = n * dt * dt / (A * c * a0)
        jmax[j] = nmax
        jsum[j] = nsum
    return jmax.max(), np.sqrt(jsum.sum() / (ni * nj * nk))


@nb.njit(cache=True, inline="always")
def _band_solve(a, b, d, e, r, n):  # pragma: no cover - compiled
    """Solve in place a banded system with two sub-diagonals (a, b), diagonal d and one super-diagonal e."""
    for i in range(n):
        if i >= 2 and a[i] != 0.0:
            m = a[i] / d[i - 2]
            b[i] -= m * e[i - 2]
            r[i] -= m * r[i - 2]
        if i >= 1 and b[i] != 0.0:
            m = b[i] / d[i - 1]
            d[i] -= m * e[i - 1]
            r[i] -= m * r[i - 1]
    r[n - 1] /= d[n - 1]
    for i in range(n - 2, -1, -1):
        r[i] = (r[i] - e[i] * r[i + 1]) / d[i]


@nb.njit(cache=True, nogil=True)
def solve_xi(phi, w, tc, co, xc, xf, cj, xiy_xf, sponge):  # pragma: no cover - compiled
    """Apply the streamwise factor's inverse to w in place (EO-switched Jacobian, far-field faces)."""
    ni, nj, nk = phi.shape
    a0, b0, dt, ku, kd = tc[0], tc[4], tc[7], tc[8], tc[9]
    A, B, E, F, H, us = co[0], co[1], co[2], co[3], co[5], co[6]
    three_d = nj > 1
    for j in range(nj):
        la = np.zeros(ni)
        lb = np.zeros(ni)
        ld = np.zeros(ni)
        le = np.zeros(ni)
        r = np.zeros(ni)
        c = cj[j]
        s = dt * dt / (A * c * a0)
        sb = s * B * b0 / dt
        for k in range(nk):
            la[:] = 0.0
            lb[:] = 0.0
            ld[:] = 1.0
            le[:] = 0.0
            for i in range(ni):
                ld[i] += sponge[i, j, k] * b0 * dt / a0
            for i in range(1, ni):
                inv1 = 1.0 / (xc[i] - xc[i - 1])
                ld[i] += sb * inv1
                lb[i] -= sb * inv1
            for f in range(1, ni):  # face f between nodes f-1 and f
                dxf = xc[f] - xc[f - 1]
                u = (phi[f, j, k] - phi[f - 1, j, k]) / (dxf * c)
                ga = (E + 2.0 * F * u) / c
                acen = 0.0
                if three_d:
                    acen = c * xiy_xf[f - 1, j] ** 2 * (1.0 + H * u)
                asub = acen + (ga if u < us else 0.0)
                asup = ga if u >= us else 0.0
                q = s * asub / (dxf * (xf[f] - xf[f - 1]))
                le[f - 1] -= q
                ld[f - 1] += q
                q = s * (asub - asup) / (dxf * (xf[f + 1] - xf[f]))
                ld[f] += q
                lb[f] -= q
                if f + 1 <= ni - 1 and asup != 0.0:
                    q = s * asup / (dxf * (xf[f + 2] - xf[f + 1]))
                    lb[f + 1] += q
                    la[f + 1] -= q
            # far-field faces: flux g(-kappa phi_t) of the end node
            ld[0] -= s * E / c * ku * b0 / dt / (xf[1] - xf[0])
            ld[ni - 1] += s * E / c * kd * b0 / dt / (xf[ni] - xf[ni - 1])
            for i in range(ni):
                r[i] = w[i, j, k]
            _band_solve(la, lb, ld, le, r, ni)
            for i in range(ni):
                w[i, j, k] = r[i]


@nb.njit(cache=True, nogil=True)
def solve_eta(phi, w, tc, co, xc, yc, yf, cj, cyf, lateral_far, root, c_root):  # pragma: no cover - compiled
    """Apply the spanwise factor's inverse to w in place (root face by ``root``, lateral far-field faces)."""
    ni, nj, nk = phi.shape
    if nj == 1:
        return
    a0, b0, dt, ky = tc[0], tc[4], tc[7], tc[11]
    A, H = co[0], co[5]
    for i in range(ni):
        la = np.zeros(nj)
        lb = np.zeros(nj)
        ld = np.zeros(nj)
        le = np.zeros(nj)
        r = np.zeros(nj)
        lo = max(i - 1, 0)
        hi = min(i + 1, ni - 1)
        inv2 = 1.0 / (xc[hi] - xc[lo])
        for k in range(nk):
            lb[:] = 0.0
            ld[:] = 1.0
            le[:] = 0.0
            for f in range(nj - 1):
                dy = yc[f + 1] - yc[f]
                u = 0.5 * ((phi[hi, f, k] - phi[lo, f, k]) + (phi[hi, f + 1, k] - phi[lo, f + 1, k])) \
                    * inv2 / cyf[f]
                alpha = cyf[f] * (1.0 + H * u) / dy
                q = dt * dt / (A * cj[f] * a0) * alpha / (yf[f + 1] - yf[f])
                ld[f] += q
                le[f] -= q
                q = dt * dt / (A * cj[f + 1] * a0) * alpha / (yf[f + 2] - yf[f + 1])
                ld[f + 1] += q
                lb[f + 1] -= q
            if lateral_far:
                ld[nj - 1] += dt * dt / (A * a0) * ky * b0 / dt / (yf[nj] - yf[nj - 1])
            if root == 1:  # antisymmetry plane: the flux c_root (phi0 - (-phi0)) / (2 yc0), u = 0 on the plane
                ld[0] += dt * dt / (A * cj[0] * a0) * 2.0 * c_root / (yc[0] + yc[0]) / (yf[1] - yf[0])
            elif root == 2:  # free wing: the lateral far field below the root
                ld[0] += dt * dt / (A * a0) * ky * b0 / dt / (yf[1] - yf[0])
            for j in range(nj):
                r[j] = w[i, j, k]
            la[:] = 0.0
            _band_solve(la, lb, ld, le, r, nj)
            for j in range(nj):
                w[i, j, k] = r[j]


@nb.njit(cache=True, nogil=True)
def solve_zeta(w, tc, co, zc, zf, wing, k0):  # pragma: no cover - compiled
    """Apply the normal factor's inverse to w in place (no coupling across the slit, far-field faces)."""
    ni, nj, nk = w.shape
    a0, b0, dt, kz = tc[0], tc[4], tc[7], tc[10]
    A = co[0]
    s = dt * dt / (A * a0)
    for j in range(nj):
        la = np.zeros(nk)
        lb = np.zeros(nk)
        ld = np.zeros(nk)
        le = np.zeros(nk)
        r = np.zeros(nk)
        for i in range(ni):
            lb[:] = 0.0
            ld[:] = 1.0
            le[:] = 0.0
            for f in range(1, nk):  # face f between nodes f-1 and f
                if f == k0 + 1 and wing[i, j]:
                    continue
                alpha = 1.0 / (zc[f] - zc[f - 1])
                q = s * alpha / (zf[f] - zf[f - 1])
                ld[f - 1] += q
                le[f - 1] -= q
                q = s * alpha / (zf[f + 1] - zf[f])
                ld[f] += q
                lb[f] -= q
            ld[0] += s * kz * b0 / dt / (zf[1] - zf[0])
            ld[nk - 1] += s * kz * b0 / dt / (zf[nk] - zf[nk - 1])
            for k in range(nk):
                r[k] = w[i, j, k]
            la[:] = 0.0
            _band_solve(la, lb, ld, le, r, nk)
            for k in range(nk):
                w[i, j, k] = r[k]
