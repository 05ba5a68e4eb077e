"""Which basis and ROMs an evaluation runs on: the wing's active basis (or one the request names).

A wing has one *active* basis. The first basis built for a wing becomes active; a later one never does
by itself (so building a basis, e.g. ``romams basis``, never changes what a running service answers),
only an explicit activation (``PUT /api/v1/wings/{id}/active-basis``, ``romams basis --activate``).
A request may name another basis of the wing (``basis_id``). On a basis, the ROM of each Mach is the
newest one trained for it with the requested solver (default: the dlm ROM where one exists, else the newest).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from romams.services.errors import Conflict, InvalidInput, NotFound
from romams.services.evaluation import Models
from romams.services.training import DEFAULT_SOLVER


def resolve_basis_id(store: Any, wing_id: int, basis_id: int | None = None) -> int:
    """The basis an evaluation of ``wing_id`` uses: ``basis_id`` when given (it must belong to the wing), else the
    wing's active basis. NotFound / Conflict naming ``basis_id``."""
    if basis_id is not None:
        if store.bases.wing_id(int(basis_id)) != int(wing_id):
            raise NotFound("basis_id", f"basis {basis_id} does not belong to wing {wing_id}")
        return int(basis_id)
    active = store.wings.active_basis(int(wing_id))
    if active is None:
        raise Conflict("basis_id", f"wing {wing_id} has no basis yet; POST /api/v1/wings/{wing_id}/basis first")
    return int(active)


def trained_rom_ids(store: Any, wing_id: int, basis_id: int, machs: Sequence[float] | None = None,
                    field: str = "machs", solver: str | None = None) -> list[list[float]]:
    """[(mach, rom_id)] of each requested (default: every trained) Mach on the basis.

    ``solver`` given: the newest ROM of that solver. Otherwise the newest ROM of the default solver (dlm) where
    one is trained, else the newest of any solver (ROMs of several solvers coexist for one Mach).
    """
    trained: dict[float, int] = {}
    preferred: dict[float, int] = {}
    for rid, mach, rom_solver in store.roms.index(wing_id, basis_id):  # oldest first: the newest of each Mach wins
        if solver is not None and rom_solver != solver:
            continue
        trained[round(mach, 6)] = rid
        if rom_solver == DEFAULT_SOLVER:
            preferred[round(mach, 6)] = rid
    trained.update(preferred)
    if not trained:
        what = "no ROM" if solver is None else f"no {solver} ROM"
        raise Conflict("solver" if solver is not None else field,
                       f"{what} is trained on basis {basis_id}; POST /api/v1/wings/{wing_id}/roms first")
    if machs is None:
        return [[m, trained[m]] for m in sorted(trained)]
    out = []
    for i, m in enumerate(machs):
        key = round(float(m), 6)
        if key not in trained:
            what = "" if solver is None else f" with solver {solver}"
            raise InvalidInput(f"{field}[{i}]", f"Mach {m} is not trained{what} on basis {basis_id}; "
                                                f"trained: {sorted(trained)}")
        out.append([key, trained[key]])
    if len({m for m, _ in out}) != len(out):
        raise InvalidInput(field, "contains duplicates")
    return sorted(out)


def load_models(wing_id: int, wing: Any, basis_id: int, rom_ids: Sequence[Sequence[float]],
                load_basis: Callable[[int], Any], load_rom: Callable[[int], Any],
                load_mesh: Callable[[int], Any]) -> Models:
    """Models of an evaluation from ids, with the caller's (possibly cached) loaders."""
    roms = {float(m): (int(rid), load_rom(int(rid))) for m, rid in rom_ids}
    return Models(int(wing_id), wing, load_mesh(int(wing_id)), int(basis_id), load_basis(int(basis_id)), roms)


def activate_first_basis(store: Any, wing_id: int, basis_id: int) -> bool:
    """Make ``basis_id`` the wing's active basis if it has none yet; True when it became active."""
    if store.wings.active_basis(int(wing_id)) is not None:
        return False
    store.wings.set_active_basis(int(wing_id), int(basis_id))
    return True
