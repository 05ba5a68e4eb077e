"""Full-order flutter references: the p-k solution (``romams_core.pk``) on a solver's own GAF table.

``uvlm_table`` tabulates the UVLM's harmonic response; ``solver_table`` that of a frequency-domain solver (the
DLM) or the UVLM; ``fom_flutter`` runs p-k on the table of a structure's own modes, with the exact-GAF
harmonic check at the flutter k for frequency-domain solvers (docs/aerodynamics.md, section 12.3).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from romams_core.atmosphere import isa, isa_table
from romams_core.errors import InputError
from romams_core.flutter import finite_positive
from romams_core.mesh import StandardMesh
from romams_core.pk import DEFAULT_ALTITUDE_REF_M, AeroTable, PkResult, pk_flutter


def uvlm_table(
    mesh: StandardMesh,
    shapes: np.ndarray,
    mach: float,
    k_max: float = 2.0,
    n_k: int = 41,
    solver: Any = None,
    derivative: str = "exact",
) -> AeroTable:
    """AeroTable of the linear UVLM for ``shapes`` [N, m] (m) at ``mach`` on k = 0 .. k_max (n_k points).

    The lattice, wake length and lattice time step are those the time-domain ``solver`` (default
    ``UvlmSolver()``) uses for training: the mesh refined ``solver.refine`` times, dt* = 1 / n_chord of the
    refined lattice, ``solver.wake_chords``; the system is assembled and factorized once (one K x K complex
    solve per k). ``derivative`` "exact" (du/dt* = i omega* u) or "bdf2" (the march's sampled derivative).
    """
    from romams_core.aero.uvlm import UvlmSolver, frequency_response, refine_mesh

    if not (math.isfinite(k_max) and k_max > 0):
        raise InputError("k_max", f"must be finite and > 0, got {k_max!r}")
    if not (isinstance(n_k, int | np.integer) and n_k >= 4):
        raise InputError("n_k", f"must be an integer >= 4, got {n_k!r}")
    solver = UvlmSolver() if solver is None else solver
    r = int(solver.refine)
    lattice, interp = refine_mesh(mesh, r)
    lattice_shapes = np.asarray(interp @ np.asarray(shapes, dtype=float))
    system = solver.build(lattice, mach, 1.0 / lattice.n_chord)  # the solver's wake, tip inset and root symmetry
    k = np.linspace(0.0, float(k_max), int(n_k))
    h = frequency_response(lattice, lattice_shapes, mach, k, derivative=derivative, system=system)
    desc = (f"UVLM frequency response, lattice refined {r}x, dt* {system.dt_star:g}, wake {solver.wake_chords:g} "
            f"chords, derivative {derivative}, root {getattr(solver, 'symmetry', 'symmetric')}")
    return AeroTable(k=k, h=h, mach=float(mach), description=desc)


def solver_table(mesh: StandardMesh, shapes: np.ndarray, mach: float, solver: Any, k_max: float,
                 n_k: int, derivative: str = "exact") -> AeroTable:
    """AeroTable on k = 0 .. k_max (n_k points) from a frequency-domain solver (``.gaf``, the DLM) or the UVLM."""
    if solver is not None and hasattr(solver, "gaf"):
        # on the grid dk * i (dk = k_max / (n_k - 1)) rounded to 1e-9, so that tables of different structures
        # share reduced frequencies and a caching solver (the DLM) reuses its factorized AICs
        k = np.round(np.linspace(0.0, float(k_max), int(n_k)), 9)
        h = solver.gaf(mesh, shapes, mach, k)
        return AeroTable(k=k, h=h, mach=float(mach), description=solver.info(mach).description)
    return uvlm_table(mesh, shapes, mach, k_max=k_max, n_k=n_k, solver=solver, derivative=derivative)


def _with_exact_point(table: AeroTable, mesh: StandardMesh, shapes: np.ndarray, solver: Any, k_f: float) -> AeroTable:
    """``table`` with the solver's exact GAF at k_f inserted (the harmonic check of the flutter root)."""
    h_f = np.asarray(solver.gaf(mesh, shapes, table.mach, np.array([k_f])), dtype=complex)
    k = np.concatenate([table.k, [k_f]])
    order = np.argsort(k)
    return AeroTable(k=k[order], h=np.concatenate([table.h, h_f])[order], mach=table.mach,
                     description=table.description + f"; exact GAF at the flutter k = {k_f:.6g}")


def fom_flutter(
    mesh: StandardMesh,
    omega: np.ndarray,
    shapes: np.ndarray,
    mach: float,
    *,
    zeta: np.ndarray | float | None = None,
    sweep: str = "constant-speed",
    solver: Any = None,
    dk: float = 0.05,
    derivative: str = "exact",
    **kwargs: Any,
) -> tuple[PkResult, AeroTable]:
    """Full-order p-k flutter of structure (omega [k] rad/s, mass-normalized shapes [N, k] m).

    ``solver``: a frequency-domain solver (``.gaf``, e.g. the DLM) or the UVLM (default ``UvlmSolver()``). Its
    GAF is tabulated once on k = 0 .. k_max in steps of about ``dk``, with k_max = 1.3 max(omega) b / V_min + 0.1
    (V_min the lowest true speed of the sweep: "constant-speed" or "matched" only), and ``pk_flutter`` runs with
    ``kwargs`` (rho_ref, a_ref, q_max, n_points, ...). A root outside the table doubles k_max (twice at most).
    Harmonic check (frequency-domain solvers): the exact GAF at the flutter k is added to the table and the
    search repeated until q_f moves by less than 1e-4 (twice at most); the message gives the last change.
    Returns (PkResult, AeroTable).
    """
    om = np.atleast_1d(np.asarray(omega, dtype=float))
    dk = finite_positive("dk", dk)
    mach_f = float(mach)
    if not (math.isfinite(mach_f) and mach_f > 0):
        raise InputError("mach", f"must be finite and > 0, got {mach!r}")
    st = isa(float(kwargs.get("altitude_ref_m", DEFAULT_ALTITUDE_REF_M)))
    a_ref = float(kwargs.get("a_ref") or st.a)
    if sweep == "matched":
        h_hi = max(float(x) for x in kwargs.get("altitude_range_m", (0.0, 20_000.0)))
        v_min = mach_f * float(isa_table(h_hi)[1])
    elif sweep == "constant-speed":
        v_min = mach_f * a_ref
    else:
        raise InputError("sweep", f"fom_flutter supports 'constant-speed' and 'matched' (a constant-density sweep "
                                  f"starts at V -> 0, i.e. k -> infinity, beyond any table), got {sweep!r}")
    k_max = 1.3 * float(np.max(om)) * 0.5 * mesh.c_ref / v_min + 0.1
    k_max = dk * math.ceil(k_max / dk)  # a multiple of dk: tables of different structures share their k values
    for attempt in range(3):  # a root beyond the table (aerodynamic stiffening) doubles the k range, twice at most
        n_k = max(4, int(round(k_max / dk)) + 1)
        table = solver_table(mesh, shapes, mach_f, solver, k_max, n_k, derivative)
        try:
            res = pk_flutter(om, table, mesh.c_ref, mach_f, sweep=sweep, zeta=zeta, **kwargs)
        except ValueError as exc:
            if not str(exc).startswith("k: reduced frequency") or attempt == 2:
                raise
            k_max *= 2.0
            continue
        return _harmonic_check(res, table, mesh, shapes, solver, om, zeta, sweep, kwargs)
    raise AssertionError("unreachable")


def _harmonic_check(res: PkResult, table: AeroTable, mesh: StandardMesh, shapes: np.ndarray, solver: Any,
                    om: np.ndarray, zeta: Any, sweep: str, kwargs: dict[str, Any]) -> tuple[PkResult, AeroTable]:
    """Repeat the p-k search with the exact GAF at the flutter k until q_f settles (frequency-domain solvers)."""
    if solver is None or not hasattr(solver, "gaf") or not res.flutter_found:
        return res, table
    change = math.inf
    for _ in range(2):
        assert res.k_flutter is not None and res.q_flutter_pa is not None
        if np.min(np.abs(table.k - res.k_flutter)) < 1e-9 * max(1.0, res.k_flutter):
            break
        table = _with_exact_point(table, mesh, shapes, solver, float(res.k_flutter))
        new = pk_flutter(om, table, mesh.c_ref, res.mach, sweep=sweep, zeta=zeta, **kwargs)
        if not new.flutter_found or new.q_flutter_pa is None:
            break
        change = abs(new.q_flutter_pa - res.q_flutter_pa) / res.q_flutter_pa
        res = new
        if change < 1e-4:
            break
    if math.isfinite(change):
        res.message += f"; harmonic check with the exact GAF at k_f: q_f changed by {change:.1e} (relative)"
    return res, table
