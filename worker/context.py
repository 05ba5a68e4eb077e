"""Per-process state of a worker: its store handle, settings, bounded object caches and the cached loaders.

Both task modules (``worker.tasks`` for training, ``worker.evaluation`` for flutter evaluations) import
this module and nothing from each other, so the worker package has no import cycle.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from romams.jobs import JobFailed, ProgressFn, run_job
from romams.persistence import Store, open_store
from romams.settings import get_settings
from worker.cache import LruCache

_STORE: list[Store] = []
settings = get_settings()
OBJECTS = LruCache(settings.cache_size)  # (kind, id) -> wing / basis / ROM / mesh / baseline evaluation


def store() -> Store:
    """This process's store (opened on first use, after any fork)."""
    if not _STORE:
        _STORE.append(open_store(settings))
    return _STORE[0]


def reset_process_state() -> None:
    """Forget the store handle (a forked pool process opens its own)."""
    _STORE.clear()


def run(job_id: str, body: Any, **kw: Any) -> Any:
    """run_job with this worker's settings."""
    return run_job(store(), job_id, body, max_deliveries=settings.max_deliveries,
                   heartbeat_s=settings.heartbeat_s, **kw)


def load_wing(wing_id: int) -> Any:
    """WingDefinition of a stored wing (cached; a stored definition never changes)."""
    def load() -> Any:
        found = store().wings.find(int(wing_id))
        if found is None:
            raise JobFailed(f"wing {wing_id} not found")
        return found[1]
    return OBJECTS.get_or_load(("wing", int(wing_id)), load)


def load_mesh(wing_id: int) -> Any:
    """Standard mesh of a stored wing (cached)."""
    from romams_core.mesh import standard_mesh

    return OBJECTS.get_or_load(("mesh", int(wing_id)), lambda: standard_mesh(load_wing(wing_id).planform))


def load_basis(basis_id: int) -> Any:
    """Basis by id (cached; a stored basis never changes)."""
    return OBJECTS.get_or_load(("basis", int(basis_id)), lambda: store().bases.load(int(basis_id)))


def load_rom(rom_id: int) -> Any:
    """TrainedRom by id (cached; a ROM row never changes, a retrained one gets a new id)."""
    return OBJECTS.get_or_load(("rom", int(rom_id)), lambda: store().roms.load(int(rom_id)))


def train_model(mesh: Any, shapes: Any, mach: float, ident: Mapping[str, Any], what: str,
                progress: ProgressFn | None = None) -> Any:
    """Train one ROM with identity ``ident`` (romams.services.training.train); a solver that is unknown or
    unavailable, or an identification that fails, fails the job with a message starting with ``what``."""
    from romams.services.training import train
    from romams_core.training import TrainingError

    try:
        return train(mesh, shapes, float(mach), ident, progress=progress)
    except (TrainingError, ValueError) as exc:
        raise JobFailed(f"{what} failed: {exc}") from exc


