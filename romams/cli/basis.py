"""``romams basis``: sample a wing's design space, build the PCA mode basis, check it on hold-out designs."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import numpy as np
import typer

from romams.cli.app import WING_HELP, app
from romams.cli.text import console, progress_bar, sig
from romams.services.evaluation import DEFAULT_MAC_THRESHOLD
from romams.services.models import activate_first_basis
from romams_core.basis import Basis, build_basis_for_wing, mac_by_basis_size, project, random_designs, snapshot
from romams_core.mesh import standard_mesh


def _resolve_wing(name: str, use_store: bool) -> Any:
    """A wing file (.json / Nastran deck), else a stored wing by name/id, else a template by name."""
    from romams.wing_files import is_wing_file, load_wing_file
    from romams_core.wing import template

    if is_wing_file(name):
        try:
            return load_wing_file(name)
        except (ValueError, ImportError) as exc:
            raise typer.BadParameter(str(exc), param_hint="--wing") from None

    if use_store:
        from romams.persistence import open_store

        found = open_store().wings.find(name)
        if found is not None:
            return found[1]
    try:
        return template(name)
    except ValueError as exc:
        raise typer.BadParameter(str(exc), param_hint="--wing") from None


def basis_arrays(basis: Basis) -> dict[str, np.ndarray]:
    """Plain named arrays of a Basis for an NPZ file (no pickles)."""
    return {
        "shapes": basis.shapes,
        "candidates": basis.candidates,
        "singular_values": basis.singular_values,
        "energy": basis.energy,
        "n_basis": np.array(basis.n_basis),
        "mac_threshold": np.array(basis.mac_threshold),
        "max_basis": np.array(basis.max_basis),
        "min_mac": np.array(basis.min_mac),
        "min_mac_by_m": basis.min_mac_by_m,
        "mac_table": basis.mac_table,
        "capped": np.array(basis.capped),
        "n_modes": np.array(basis.n_modes),
        "designs": basis.designs,
        "design_names": np.array(basis.design_names, dtype=str),
        "wing_name": np.array(basis.wing_name),
    }


@app.command("basis")
def basis_command(
    wing: str = typer.Option("cropped-delta", "--wing", help=WING_HELP),
    samples: int = typer.Option(25, "--samples", min=1, help="Latin hypercube samples of the design space"),
    modes: int = typer.Option(4, "--modes", min=1, max=50, help="modes per sample structure"),
    mac: float = typer.Option(DEFAULT_MAC_THRESHOLD, "--mac", min=0.0, max=1.0,
                              help="MAC threshold epsilon for choosing m (default 0.9999: ROM-AMS within 1 %)"),
    seed: int = typer.Option(0, "--seed", help="seed of the LHS (hold-out designs use seed + 1000)"),
    max_basis: int = typer.Option(12, "--max-basis", min=1, help="cap on the number of basis shapes"),
    holdout: int = typer.Option(20, "--holdout", min=0, help="random hold-out designs to check the fit on"),
    as_json: bool = typer.Option(False, "--json", help="print one JSON object"),
    out: Path | None = typer.Option(None, "--out", help="also write the basis to this NPZ file"),
    plot: Path | None = typer.Option(None, "--plot", help="write PNG figures into this directory"),
    store: bool = typer.Option(True, "--store/--no-store", help="save the basis in the local store"),
    activate: bool = typer.Option(False, "--activate", help="make it the wing's active basis (the first basis of a "
                                                           "wing becomes active anyway; a later one only with this)"),
    snapshots: list[Path] | None = typer.Option(None, "--snapshots", help="build the basis from these mode sets "
                                                "(JSON/NPZ files, one per design of your own design space; repeat) "
                                                "instead of sampling the built-in structure"),
) -> None:
    """Build the PCA basis of mode shapes for a wing and report its fit (MAC) on samples and hold-out designs."""
    if not 0.0 < mac < 1.0:
        raise typer.BadParameter("must be in (0, 1)", param_hint="--mac")
    w = _resolve_wing(wing, store)
    t0 = time.perf_counter()
    if snapshots:
        basis = _snapshot_basis(w, snapshots, modes, mac, max_basis)
        samples, holdout = len(snapshots), 0  # no design space of ours to draw hold-out designs from
    else:
        try:
            with progress_bar(console(), f"modal analyses of {samples} samples") as bar:
                basis = build_basis_for_wing(w, samples=samples, modes=modes, mac_threshold=mac,
                                             max_basis=max_basis, seed=seed, progress=bar)
        except ValueError as exc:
            raise typer.BadParameter(str(exc)) from None
    t_build = time.perf_counter() - t0
    report: dict[str, Any] = {
        "wing": getattr(w, "name", wing),
        "n_basis": basis.n_basis,
        "min_mac_samples": round(basis.min_mac, 6),
        "holdout_min_mac": None,
        "capped": basis.capped,
        "mac_threshold": basis.mac_threshold,
        "samples": samples,
        "modes": modes,
        "singular_values": [round(float(x), 6) for x in basis.singular_values[: max(max_basis, basis.n_basis)]],
        "min_mac_samples_by_m": [round(float(x), 6) for x in basis.min_mac_by_m],
        "build_s": round(t_build, 3),
    }
    hold_shapes: list[np.ndarray] = []
    if holdout:
        designs = random_designs(w, holdout, seed=seed + 1000)
        with progress_bar(console(), f"modal analyses of {holdout} hold-out designs") as bar:
            for i, x in enumerate(designs):
                hold_shapes.append(snapshot(w, x, modes))
                bar((i + 1) / len(designs), "")
        hold = np.vstack([project(basis.shapes, s, mac).mac for s in hold_shapes])  # [holdout, modes]
        by_m = np.stack([mac_by_basis_size(basis.candidates, s).min(axis=1) for s in hold_shapes]).min(axis=0)
        report.update(
            holdout_min_mac=round(float(hold.min()), 6),
            holdout_min_mac_by_mode=[round(float(x), 6) for x in hold.min(axis=0)],
            holdout_designs=holdout,
            holdout_min_mac_by_m=[round(float(x), 6) for x in by_m],
            holdout_poor_fits=int(np.sum(hold < mac)),
        )
    if store:
        from romams.persistence import open_store

        params: dict[str, Any] = {"samples": samples, "modes": modes, "mac_threshold": mac, "max_basis": max_basis,
                                  "seed": seed}
        if snapshots:
            params = {"snapshots": [p.name for p in snapshots], "modes": modes, "mac_threshold": mac,
                      "max_basis": max_basis}
        with open_store().unit_of_work() as uow:  # stored and (if asked, or first) activated together
            wing_id = uow.wings.ensure(w)
            report["wing_id"] = wing_id
            report["basis_id"] = uow.bases.save(wing_id, basis, params)
            if activate:
                uow.wings.set_active_basis(wing_id, report["basis_id"])
            else:
                activate_first_basis(uow, wing_id, report["basis_id"])
            report["active_basis_id"] = uow.wings.active_basis(wing_id)
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(out, **basis_arrays(basis))
        report["out"] = str(out)
    if plot is not None:
        report["plots"] = _write_plots(plot, w, basis, hold_shapes)
    if as_json:
        typer.echo(json.dumps(report))
        return
    typer.echo(basis.message)
    typer.echo(f"samples: {samples} x {modes} modes, worst sample MAC {basis.min_mac:.5f} ({sig(t_build)} s wall)")
    if holdout:
        per_mode = ", ".join(f"{x:.5f}" for x in report["holdout_min_mac_by_mode"])
        typer.echo(f"hold-out: {holdout} designs, worst MAC per mode {per_mode}")
    if "basis_id" in report:
        typer.echo(f"stored as basis {report['basis_id']} of wing {report['wing_id']}")


def _snapshot_basis(wing: Any, files: list[Path], modes: int, mac: float, max_basis: int) -> Basis:
    """Basis of the user's mode sets (``romams.services.snapshot_basis``), usage errors naming --snapshots."""
    from romams.cli.flutter import external_modes
    from romams.services.errors import ServiceError
    from romams.services.snapshot_basis import snapshot_basis

    sets = [external_modes(f, None) for f in files]
    try:
        return snapshot_basis(wing, sets, modes, mac, max_basis, field="--snapshots")
    except ServiceError as exc:
        i = str(exc.field).partition("[")[2].rstrip("]")
        where = f" ({files[int(i)].name})" if i.isdigit() else ""
        raise typer.BadParameter(exc.reason + where, param_hint="--snapshots") from None


def _write_plots(directory: Path, wing: Any, basis: Basis, hold_shapes: list[np.ndarray]) -> list[str]:
    """Basis shapes, MAC vs m and original-vs-fitted PNGs; returns the file paths."""
    from romams.plots.basis import plot_basis_shapes, plot_fit_comparison, plot_mac_vs_basis_size, save

    directory.mkdir(parents=True, exist_ok=True)
    mesh = standard_mesh(wing.planform)
    paths = []
    p = directory / "basis_shapes.png"
    save(plot_basis_shapes(mesh, basis.shapes, basis.singular_values), str(p))
    paths.append(str(p))
    if hold_shapes:
        worst = int(np.argmin([project(basis.shapes, s, basis.mac_threshold).min_mac for s in hold_shapes]))
        shapes = hold_shapes[worst]
        curves = mac_by_basis_size(basis.candidates, shapes)
        title = f"fit MAC vs basis size (worst hold-out design #{worst + 1})"
    else:
        shapes = snapshot(wing, basis.designs[0], basis.n_modes)
        curves = basis.min_mac_by_m[: basis.candidates.shape[1], None]
        title = "worst sample MAC vs basis size"
    p = directory / "mac_vs_basis_size.png"
    labels = None if hold_shapes else ["worst sample"]
    save(plot_mac_vs_basis_size(curves, basis.mac_threshold, basis.n_basis, title, labels), str(p))
    paths.append(str(p))
    proj = project(basis.shapes, shapes, basis.mac_threshold)
    p = directory / "fit_comparison.png"
    save(plot_fit_comparison(mesh, shapes, proj.fitted, proj.mac), str(p))
    paths.append(str(p))
    return paths
