"""A PCA basis built from mode sets the user supplies (uploaded modes of many designs of a design space the product
cannot compute itself): the one use case behind ``POST /wings/{wing}/basis/snapshots`` and ``romams basis
--snapshots``. Each set is mapped onto the wing's standard mesh as an evaluation's uploaded modes are
(``romams_core.modes_io.wing_modal_result``); its first ``modes`` modes by frequency are the snapshots, and the
basis is ``romams_core.basis.build_basis`` of them, as for the built-in plate's LHS samples."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from romams.services.errors import InvalidInput
from romams_core.basis import Basis, build_basis
from romams_core.errors import InputError
from romams_core.mesh import standard_mesh

#: fewest and most mode sets of a snapshot basis
MIN_SETS, MAX_SETS = 2, 1000


def snapshot_basis(wing: Any, mode_sets: Sequence[Any], modes: int = 4, mac_threshold: float = 0.9999,
                   max_basis: int = 12, field: str = "modes_ids") -> Basis:
    """Basis of the first ``modes`` modes of each ExternalModes set in ``mode_sets`` (InvalidInput naming
    ``field[i]`` for a set that does not map onto the wing or has too few modes)."""
    from romams_core.modes_io import wing_modal_result

    if not MIN_SETS <= len(mode_sets) <= MAX_SETS:
        raise InvalidInput(field, f"need {MIN_SETS} to {MAX_SETS} mode sets, got {len(mode_sets)}")
    mesh = standard_mesh(wing.planform)
    snaps = []
    for i, m in enumerate(mode_sets):
        try:
            shapes = wing_modal_result(m, wing, mesh).shapes
        except (InputError, ValueError) as exc:
            raise InvalidInput(f"{field}[{i}]", str(exc)) from None
        if shapes.shape[1] < modes:
            raise InvalidInput(f"{field}[{i}]", f"has {shapes.shape[1]} modes; the basis takes {modes} per set")
        snaps.append(shapes[:, :modes])
    try:
        return build_basis(np.hstack(snaps), mac_threshold=mac_threshold, max_basis=max_basis, n_modes=modes,
                           wing_name=str(getattr(wing, "name", "")))
    except InputError as exc:
        raise InvalidInput(exc.field if exc.field != "snapshots" else field, exc.reason) from None
