"""In-process ROM-AMS pipeline on the local store: wing -> basis -> ROMs per Mach -> flutter evaluation.

The CLI (``romams basis/train/flutter/demo``) uses these functions; the service's Celery tasks do the
same steps as jobs. Both read and write the one store (``romams.store``), so a basis or ROM built by
one is found by the other (ROM identity = solver, ARX orders and training options, as in the API).
``make_solver`` and ``rom_identity`` live in ``romams.services.training`` (re-exported here).
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from contextlib import AbstractContextManager, nullcontext
from typing import Any

import numpy as np

from romams.services.evaluation import DEFAULT_MAC_THRESHOLD, DEFAULT_N_MODES, Models
from romams.services.models import activate_first_basis, resolve_basis_id
from romams.services.training import is_external, is_frequency_solver, quality_line, rom_identity, train
from romams.services.training import make_solver as make_solver  # re-exported
from romams_core.basis import Basis, build_basis, build_basis_for_wing, snapshot
from romams_core.mesh import StandardMesh, standard_mesh
from romams_core.wing import WingDefinition, template

Log = Callable[[str], None]
#: fraction done (0-1), message (a CLI progress bar)
Progress = Callable[[float, str], None]

#: Mach numbers of the ROM-AMS paper's envelope.
PAPER_MACHS = (0.79, 0.83, 0.87, 0.91, 0.95)


def _stderr(msg: str) -> None:
    """Default log: one line on stderr (keeps stdout clean for --json)."""
    print(msg, file=sys.stderr, flush=True)


def resolve_wing(store: Any, name: str) -> tuple[int, WingDefinition]:
    """(id, wing) of a wing file (.json / Nastran deck, stored under its name), else of a stored wing by name or
    id, else the template of that name stored under its name."""
    from romams.wing_files import is_wing_file, load_wing_file, store_wing

    if is_wing_file(name):
        wing = load_wing_file(name)
        return store_wing(store, wing), wing
    found = store.wings.find(name)
    if found is not None:
        return int(found[0]), found[1]
    wing = template(name)  # ValueError naming the unknown template
    return int(store.wings.ensure(wing)), wing


def basis_params(samples: int, modes: int, mac_threshold: float, max_basis: int, seed: int) -> dict[str, Any]:
    """The parameters that identify a basis build (as stored with it)."""
    return {"samples": int(samples), "modes": int(modes), "mac_threshold": float(mac_threshold),
            "max_basis": int(max_basis), "seed": int(seed)}


def own_mode_basis(wing: WingDefinition, modes: int, shapes: np.ndarray | None = None) -> Basis:
    """Basis of a wing without design variables: its own first ``modes`` mode shapes (orthonormalized); of a
    planform-only wing: the given external ``shapes`` [N, k] on its standard mesh."""
    if shapes is None:
        shapes = snapshot(wing, None, modes)
    else:
        modes = int(shapes.shape[1])
    return build_basis(shapes, mac_threshold=0.99999, max_basis=modes, n_modes=modes,
                       designs=np.zeros((1, 0)), design_names=[], wing_name=wing.name)


def ensure_basis(
    store: Any,
    wing_id: int,
    wing: WingDefinition,
    *,
    samples: int = 25,
    modes: int = DEFAULT_N_MODES,
    mac_threshold: float = DEFAULT_MAC_THRESHOLD,
    max_basis: int = 12,
    seed: int = 0,
    log: Log = _stderr,
    external: np.ndarray | None = None,
    progress: Progress | None = None,
) -> tuple[int, Basis]:
    """(id, Basis): the stored basis built with these parameters, else build it now (saying so) and store it.

    ``external``: shapes [N, k] on the standard mesh, the basis of a planform-only wing.

    A newly built basis becomes the wing's active basis only when the wing has none yet.
    """
    params: dict[str, Any] = basis_params(samples, modes, mac_threshold, max_basis, seed)
    if wing.structure is None:  # planform only: the basis is the external modes given for it
        if external is None:
            raise ValueError(f"modes: wing {wing.name!r} is planform-only (no built-in structure); its basis comes "
                             "from its modes: give them (--modes)")
        import hashlib

        digest = hashlib.sha256(np.ascontiguousarray(external, dtype=float).tobytes()).hexdigest()[:16]
        params.update(modes=int(external.shape[1]), external_modes=digest)
    for row in store.bases.of_wing(wing_id):
        if {k: row["params"].get(k) for k in params} == params:
            return int(row["id"]), store.bases.load(int(row["id"]))
    t0 = time.perf_counter()
    if wing.structure is None:
        log(f"wing {wing.name!r} is planform-only: its {params['modes']} external modes are its basis")
        basis = own_mode_basis(wing, modes, external)
    elif not wing.design_variables:
        log(f"wing {wing.name!r} has no design variables: its own {modes} modes are its basis")
        basis = own_mode_basis(wing, modes)
    else:
        log(f"building the PCA basis of {wing.name!r}: {samples} LHS samples x {modes} modes, MAC >= {mac_threshold:g}")
        basis = build_basis_for_wing(wing, samples=samples, modes=modes, mac_threshold=mac_threshold,
                                     max_basis=max_basis, seed=seed, progress=progress)
    bid = store.bases.save(wing_id, basis, params)
    active = activate_first_basis(store, wing_id, bid)
    log(f"basis {bid}: {basis.n_basis} shapes, worst sample MAC {basis.min_mac:.5f} ({time.perf_counter() - t0:.1f} s)"
        + (", now the wing's active basis" if active else ""))
    return int(bid), basis


def parallel_map(fn: Callable[[Any], Any], items: Sequence[Any], processes: int | None = None,
                 progress: Progress | None = None) -> list[Any]:
    """Map ``fn`` over ``items`` in up to ``processes`` worker processes (default: CPU count), in order;
    ``progress(fraction, message)`` after each item done."""
    n = min(len(items), processes or os.cpu_count() or 1)
    out: list[Any] = [None] * len(items)

    def done(k: int) -> None:
        if progress is not None:
            progress(k / max(len(items), 1), f"{k}/{len(items)} done")

    if n <= 1:
        for i, x in enumerate(items):
            out[i] = fn(x)
            done(i + 1)
        return out
    with ProcessPoolExecutor(max_workers=n) as pool:
        futures = {pool.submit(fn, x): i for i, x in enumerate(items)}
        for k, fut in enumerate(as_completed(futures), 1):
            out[futures[fut]] = fut.result()
            done(k)
    return out


def train_shapes(mesh: StandardMesh, shapes: np.ndarray, machs: Sequence[float], ident: Mapping[str, Any],
                 processes: int | None = None, progress: Progress | None = None) -> list[Any]:
    """Train one ROM per Mach on ``shapes`` [N, m] (in parallel processes); returns TrainedRoms in order."""
    return train_shape_sets(mesh, [shapes], machs, ident, processes, progress)[0]


def _train_group(args: tuple[StandardMesh, list[np.ndarray], float, dict[str, Any]]) -> list[Any]:
    """Worker-process body: train one ROM per shape set at one Mach (top level so it pickles)."""
    mesh, sets, mach, ident = args
    return [train(mesh, shapes, mach, ident) for shapes in sets]


def train_shape_sets(mesh: StandardMesh, shape_sets: Sequence[np.ndarray], machs: Sequence[float],
                     ident: Mapping[str, Any], processes: int | None = None,
                     progress: Progress | None = None) -> list[list[Any]]:
    """ROMs of several shape sets (e.g. the own modes of several structures) at every Mach: out[i][j] is set i at
    machs[j], trained in parallel processes. With a frequency-domain solver one process trains every set of a
    Mach, so its per-process cache of factorized AICs (one per Mach and reduced frequency) is built once per Mach;
    a time-domain solver's runs share nothing, so every (set, Mach) is a task of its own."""
    if processes == 1:  # in this process, Mach by Mach (the AIC cache's order), with the solvers' own progress
        n, out = len(shape_sets) * len(machs), [[None] * len(machs) for _ in shape_sets]

        def part(k: int) -> Progress | None:
            return None if progress is None else (lambda frac, msg: progress((k + frac) / n, msg))

        for j, m in enumerate(machs):
            for i, shapes in enumerate(shape_sets):
                out[i][j] = train(mesh, shapes, float(m), ident, progress=part(j * len(shape_sets) + i))
        return out
    if is_frequency_solver(str(ident.get("solver", ""))):
        groups = [(mesh, list(shape_sets), float(m), dict(ident)) for m in machs]
        by_mach = parallel_map(_train_group, groups, processes, progress)
        return [[by_mach[j][i] for j in range(len(machs))] for i in range(len(shape_sets))]
    flat = parallel_map(_train_group, [(mesh, [shapes], float(m), dict(ident)) for shapes in shape_sets
                                       for m in machs], processes, progress)
    n = len(machs)
    return [[rom for (rom,) in flat[i * n:(i + 1) * n]] for i in range(len(shape_sets))]


def ensure_roms(
    store: Any,
    wing_id: int,
    wing: WingDefinition,
    basis_id: int,
    basis: Basis,
    machs: Sequence[float],
    *,
    ident: Mapping[str, Any] | None = None,
    processes: int | None = None,
    log: Log = _stderr,
    progress: Progress | None = None,
) -> dict[float, tuple[int, Any]]:
    """{mach: (rom_id, TrainedRom)}: stored ROMs with this identity, training the missing ones (in parallel)."""
    ident = dict(ident or rom_identity())
    out: dict[float, tuple[int, Any]] = {}
    missing = []
    for mach in machs:
        found = store.roms.find(wing_id, basis_id, float(mach), ident)
        if found is None:
            missing.append(float(mach))
        else:
            out[float(mach)] = (int(found[0]), found[1])
    if missing and is_external(str(ident["solver"])):  # an imported table is never trained here
        make_solver(str(ident["solver"]))  # raises the ValueError that says how to import it
    if missing:
        log(f"training {len(missing)} ROM(s) with {ident['solver']} on {basis.n_basis} basis shapes at Mach "
            + ", ".join(f"{m:g}" for m in missing))
        t0 = time.perf_counter()
        roms = train_shapes(standard_mesh(wing.planform), basis.shapes, missing, ident, processes, progress)
        for mach, rom in zip(missing, roms, strict=True):
            rid = store.roms.save(wing_id, basis_id, rom, ident)
            out[mach] = (int(rid), rom)
            log(f"  M = {mach:g}: rom {rid}, {quality_line(rom)}, "
                f"{rom.train_seconds:.1f} s")
        log(f"trained in {time.perf_counter() - t0:.1f} s wall")
    return {m: out[float(m)] for m in sorted(out)}


def cli_models(store: Any, wing_id: int, wing: WingDefinition, machs: Sequence[float], ident: Mapping[str, Any], *,
               basis_id: int | None = None, samples: int = 25, modes: int = DEFAULT_N_MODES,
               mac_threshold: float = DEFAULT_MAC_THRESHOLD, processes: int | None = None,
               log: Log = _stderr, external: np.ndarray | None = None,
               bar: Callable[[str], AbstractContextManager[Progress | None]] | None = None) -> Models:
    """Models of a local evaluation: the named or active basis (built and activated when the wing has none)
    and one ROM per Mach with identity ``ident`` (trained when missing). A planform-only wing's basis: the
    ``external`` shapes [N, k] (its modes on the standard mesh), found again when the same modes come back.
    ``bar(description)``: a progress bar (context manager yielding the callback) around each build or training."""
    bar = bar or (lambda what: nullcontext(None))
    if basis_id is None and (store.wings.active_basis(wing_id) is None or wing.structure is None):
        with bar("basis: modal analyses of the samples") as progress:
            bid, basis = ensure_basis(store, wing_id, wing, samples=samples, modes=modes,
                                      mac_threshold=mac_threshold, log=log, external=external, progress=progress)
    else:
        bid = resolve_basis_id(store, wing_id, basis_id)
        basis = store.bases.load(bid)
    with bar(f"ROMs at {len(machs)} Mach(s)") as progress:
        roms = ensure_roms(store, wing_id, wing, bid, basis, machs, ident=ident, processes=processes, log=log,
                           progress=progress)
    return Models(int(wing_id), wing, standard_mesh(wing.planform), int(bid), basis, roms)
