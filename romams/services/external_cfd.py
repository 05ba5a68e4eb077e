"""External CFD in the time domain: the training package a CFD engineer runs, and the identification of the GAC
time histories they send back (``romams_core.external_cfd``). The one use case behind ``romams train
--export-package`` / ``--gac`` and ``GET .../external-package`` / ``POST .../roms/gac``.

The package is a zip: ``excitation.npz`` (every array), ``excitation.csv`` and ``shapes.csv`` (the same as text),
``settings.json`` (what the upload must repeat) and ``README.md`` (conventions for the CFD engineer). The ROM is
identified by ``train_rom`` with a ``RecordedSolver`` and stored as solver "external:<label>", one per (wing, basis,
Mach, label): importing again replaces it.
"""

from __future__ import annotations

import io
import json
import zipfile
from typing import Any

import numpy as np

from romams.services.errors import InvalidInput, PayloadTooLarge
from romams.services.gaf_import import external_solver_name
from romams.services.training import rom_identity
from romams_core.aero.protocol import check_mach
from romams_core.errors import InputError
from romams_core.external_cfd import RecordedSolver, check_gac, excitation, signal_settings
from romams_core.mesh import standard_mesh

#: the settings of a package: the signal settings and the ARX orders
PACKAGE_SETTINGS = ("n_steps", "dt_star", "k_max", "seed", "displacement_fraction", "na", "nb")
#: largest GAC upload (bytes)
MAX_GAC_BYTES = 64 << 20

README = """# romams external CFD training package

Wing {wing!r}, basis {basis_id} ({m} shapes), Mach {mach:g}. Run your unsteady CFD once, from a converged steady
solution at this Mach number, with the wing surface moving as described below, and send back the generalized
aerodynamic coefficients (GAC) at every sample.

## Files
- `shapes.csv`: node, x, y (m) of the {n_nodes} standard-mesh nodes (x downstream, y spanwise from the root,
  half wing with a symmetry plane at y = 0), then phi_0 ... phi_{m_1}: the basis shapes, out-of-plane displacement
  z (m, positive up) per unit generalized displacement. Interpolate them onto your surface as you would modes.
- `excitation.csv`: step n, t* = n dt*, then u_0 ... u_{m_1}: the generalized displacements (dimensionless).
  The surface displacement at sample n is z(x, y, t_n) = sum_j u_j[n] phi_j(x, y). There are {n_samples}
  samples, dt* = {dt_star:g}: one continued run from rest (u = 0 before n = 0): the first {n_steps} are the
  training half, the rest the validation half.
- `excitation.npz`: the same arrays (x, y, shapes [N, m], signals [T, m]) and the scalars below.
- `settings.json`: the training settings; send them back unchanged with the upload.

## Time
Nondimensional time t* = t V / c_ref, c_ref = {c_ref:g} m, V the free-stream speed of your run: the physical
step is dt = dt* c_ref / V. The motion is small (peak surface displacement {peak:g} c_ref) and linear ROMs are
identified about your steady solution.

## What to send back
`gac` [{n_samples}, {m}]: f_i(t_n) = (1/q) * integral over the wing (upper minus lower surface) of dp(x, y, t_n)
phi_i(x, y) dS, in m^3, dp positive up (the lower-surface pressure minus the upper's), q = rho V^2 / 2, at the
same samples as the excitation, including n = 0. As NPZ (array `gac`) or CSV (header g_0 ... g_{m_1}, one line per
sample). Upload it with a label of your choosing: the ROM is stored as solver external:<label>.
"""


def _mach(mach: Any) -> float:
    """A subsonic Mach number (``check_mach``; InvalidInput naming ``mach``)."""
    try:
        return check_mach(mach, upper=1.0)
    except InputError as exc:
        raise InvalidInput("mach", exc.reason) from None


def package_settings(mesh: Any, n_shapes: int, options: dict[str, Any] | None = None) -> dict[str, Any]:
    """The settings of a package: ``options`` (n_steps, dt_star, k_max, seed, displacement_fraction, na, nb) with
    ``train_rom``'s defaults filled in; InvalidInput naming an unknown or invalid setting."""
    opts = dict(options or {})
    unknown = sorted(set(opts) - set(PACKAGE_SETTINGS))
    if unknown:
        raise InvalidInput(f"options.{unknown[0]}", f"not a setting of an external run; allowed: "
                                                    f"{', '.join(PACKAGE_SETTINGS)}")
    na, nb = opts.pop("na", 8), opts.pop("nb", 8)
    for key, v in (("na", na), ("nb", nb)):
        if isinstance(v, bool) or not isinstance(v, int) or not 1 <= v <= 40:
            raise InvalidInput(f"options.{key}", f"must be an integer in [1, 40], got {v!r}")
    try:
        settings = signal_settings(mesh, n_shapes, na, nb, **opts)
    except (TypeError, ValueError) as exc:
        raise InvalidInput("options", str(exc)) from None
    return {**settings, "na": na, "nb": nb}


def export_package(wing: Any, basis_id: int, basis: Any, mach: float, options: dict[str, Any] | None = None
                   ) -> tuple[bytes, dict[str, Any]]:
    """(zip bytes, settings) of the training package of ``basis`` at ``mach``."""
    mach = _mach(mach)
    mesh = standard_mesh(wing.planform)
    settings = package_settings(mesh, basis.n_basis, options)
    settings["mach"] = float(mach)
    try:
        signals = excitation(mesh, basis.shapes, settings)
    except InputError as exc:
        raise InvalidInput(f"options.{exc.field}", exc.reason) from None
    m, n_nodes = basis.n_basis, mesh.n_nodes
    cols = ",".join(f"u_{j}" for j in range(m))
    steps = np.arange(signals.shape[0])
    exc_csv = np.column_stack([steps, steps * settings["dt_star"], signals])
    shp_csv = np.column_stack([np.arange(n_nodes), mesh.x, mesh.y, basis.shapes])
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        arrays = io.BytesIO()
        np.savez(arrays, x=mesh.x, y=mesh.y, shapes=basis.shapes, signals=signals, c_ref=np.float64(mesh.c_ref),
                 **{k: np.float64(v) for k, v in settings.items()})
        z.writestr("excitation.npz", arrays.getvalue())
        z.writestr("excitation.csv", _csv(f"step,t_star,{cols}", exc_csv))
        z.writestr("shapes.csv", _csv("node,x,y," + ",".join(f"phi_{j}" for j in range(m)), shp_csv))
        z.writestr("settings.json", json.dumps({"basis_id": int(basis_id), **settings}, indent=2))
        z.writestr("README.md", README.format(wing=wing.name, basis_id=basis_id, m=m, m_1=m - 1, mach=float(mach),
                                              n_nodes=n_nodes, n_samples=signals.shape[0],
                                              n_steps=settings["n_steps"], dt_star=settings["dt_star"],
                                              c_ref=mesh.c_ref, peak=settings["displacement_fraction"]))
    return buf.getvalue(), settings


def _csv(header: str, rows: np.ndarray) -> str:
    """CSV text of ``rows`` under ``header`` (full float precision)."""
    out = io.StringIO()
    np.savetxt(out, rows, delimiter=",", header=header, comments="", fmt="%.17g")
    return out.getvalue()


def parse_gac(data: bytes, filename: str = "") -> np.ndarray:
    """GAC [T, m] from NPZ (array ``gac``) or CSV (header g_0 ... g_{m-1}) bytes."""
    if len(data) > MAX_GAC_BYTES:
        raise PayloadTooLarge("file", f"{len(data)} bytes; at most {MAX_GAC_BYTES}")
    if data.startswith(b"PK"):
        try:
            with np.load(io.BytesIO(data), allow_pickle=False) as z:
                if "gac" not in z.files:
                    raise InvalidInput("gac", f"missing from the NPZ file (has {sorted(z.files)})")
                return np.asarray(z["gac"])
        except (ValueError, OSError, zipfile.BadZipFile) as exc:
            raise InvalidInput("file", f"not a readable NPZ file ({type(exc).__name__})") from None
    try:
        arr = np.loadtxt(io.StringIO(data.decode("utf-8")), delimiter=",", skiprows=1, ndmin=2)
        if arr.size == 0:
            raise ValueError("no numbers")
        return arr
    except (UnicodeDecodeError, ValueError):
        raise InvalidInput("file", f"{filename or 'the file'}: neither an NPZ file nor a CSV of numbers under a "
                                   "header g_0,...") from None


def import_gac(store: Any, wing_id: int, wing: Any, basis_id: int, basis: Any, mach: float, gac: Any, label: str,
               options: dict[str, Any] | None = None, nrmse_tol: float = 0.02) -> tuple[int, Any]:
    """(rom_id, TrainedRom): the ARX ROM identified from GAC [2 n_steps, m] computed for the package of these
    ``options`` at ``mach``, stored as solver "external:<label>"."""
    from romams_core.training import TrainingError, train_rom

    name = external_solver_name(label)
    mach = _mach(mach)
    given = (options or {}).get("mach")
    if given is not None and abs(float(given) - float(mach)) > 1e-9:
        raise InvalidInput("mach", f"the package was made for M {given}, the upload says {mach}")
    mesh = standard_mesh(wing.planform)
    settings = package_settings(mesh, basis.n_basis, {k: v for k, v in (options or {}).items()
                                                      if k not in ("mach", "basis_id")})
    na, nb = settings.pop("na"), settings.pop("nb")
    try:
        signals = excitation(mesh, basis.shapes, settings)
        recorded = check_gac(gac, signals.shape[0], basis.n_basis)
        solver = RecordedSolver(signals, recorded, float(mach), name=name,
                                source=f"external CFD GAC {label!r}")
        rom = train_rom(mesh, basis.shapes, float(mach), solver, na=na, nb=nb, nrmse_tol=nrmse_tol, **settings)
    except InputError as exc:
        raise InvalidInput(exc.field if exc.field == "gac" else f"options.{exc.field}", exc.reason) from None
    except TrainingError as exc:
        raise InvalidInput("gac", f"no ROM meets the validation tolerance from these GAC: {exc}") from None
    rid = store.roms.save(wing_id, basis_id, rom, rom_identity(name))
    return int(rid), rom
