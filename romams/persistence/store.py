"""The store: the database of one service (engine + settings), opened once per process.

``store.unit_of_work()`` groups several repository calls in one transaction. For a single call the
repository properties are shorter: ``store.jobs.get(job_id)`` runs in a unit of work of its own.
"""

from __future__ import annotations

import fcntl
from typing import Any, cast

from sqlalchemy import Engine, text
from sqlalchemy.orm import sessionmaker

from romams.persistence.artifacts import ArtifactRepository
from romams.persistence.bases import BasisRepository
from romams.persistence.engine import get_engine, head_revision, schema_revision, sqlite_path, upgrade
from romams.persistence.errors import translate
from romams.persistence.evaluations import EvaluationRepository
from romams.persistence.jobs import JobRepository
from romams.persistence.modes import ModesRepository
from romams.persistence.roms import RomRepository
from romams.persistence.runs import RunRepository
from romams.persistence.unit_of_work import UnitOfWork
from romams.persistence.wings import WingRepository
from romams.settings import Settings, get_settings


class _OneCall:
    """Stand-in for a repository whose every method call runs in a unit of work of its own."""

    def __init__(self, store: Store, name: str) -> None:
        self._store, self._name = store, name

    def __getattr__(self, method: str) -> Any:
        if method.startswith("_"):
            raise AttributeError(method)

        def call(*args: Any, **kwargs: Any) -> Any:
            with self._store.unit_of_work() as uow:
                return getattr(getattr(uow, self._name), method)(*args, **kwargs)

        call.__name__ = method
        return call


class Store:
    """The database: units of work, one-call repositories and a liveness check."""

    def __init__(self, engine: Engine, settings: Settings | None = None) -> None:
        self.engine = engine
        self.settings = settings or get_settings()
        self._sessions = sessionmaker(engine, expire_on_commit=False)

    def unit_of_work(self) -> UnitOfWork:
        """A new unit of work (one session); use it in a ``with`` block."""
        return UnitOfWork(self._sessions())

    def ping(self) -> str:
        """Run ``SELECT 1``; the database dialect name (raises when the database is unreachable)."""
        try:
            with self.engine.connect() as conn:
                conn.execute(text("SELECT 1"))
        except Exception as exc:
            mapped = translate(exc)
            if mapped is None:
                raise
            raise mapped from exc
        return self.engine.dialect.name

    # one-call repositories: each method call is its own unit of work
    @property
    def wings(self) -> WingRepository:
        return cast(WingRepository, _OneCall(self, "wings"))

    @property
    def bases(self) -> BasisRepository:
        return cast(BasisRepository, _OneCall(self, "bases"))

    @property
    def roms(self) -> RomRepository:
        return cast(RomRepository, _OneCall(self, "roms"))

    @property
    def evaluations(self) -> EvaluationRepository:
        return cast(EvaluationRepository, _OneCall(self, "evaluations"))

    @property
    def modes(self) -> ModesRepository:
        return cast(ModesRepository, _OneCall(self, "modes"))

    @property
    def jobs(self) -> JobRepository:
        return cast(JobRepository, _OneCall(self, "jobs"))

    @property
    def artifacts(self) -> ArtifactRepository:
        return cast(ArtifactRepository, _OneCall(self, "artifacts"))

    @property
    def runs(self) -> RunRepository:
        return cast(RunRepository, _OneCall(self, "runs"))


def open_store(settings: Settings | None = None, *, migrate: bool | None = None) -> Store:
    """Store on the configured database. SQLite (or ``migrate=True``) gets its directory created and is upgraded
    to Alembic head under a file lock; otherwise a schema that is not at head is refused."""
    settings = settings or get_settings()
    url = settings.db_url
    sqlite = url.startswith("sqlite")
    if sqlite:
        path = sqlite_path(url)
        if path is not None:
            path.parent.mkdir(parents=True, exist_ok=True)
    engine = get_engine(url, connect_timeout_s=settings.db_connect_timeout_s, pool_size=settings.pool_size)
    if migrate if migrate is not None else sqlite:
        db_file = sqlite_path(url) if sqlite else None  # a server database locks in the data directory
        lock_path = (db_file or settings.data_dir / "romams.db").with_suffix(".migrate.lock")
        lock_path.parent.mkdir(parents=True, exist_ok=True)
        with open(lock_path, "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            if schema_revision(engine) != head_revision():
                upgrade(url)
    else:
        current = schema_revision(engine)
        if current != head_revision():
            raise RuntimeError(f"database: schema at revision {current!r}, this code needs {head_revision()!r}; "
                               "run `alembic upgrade head` (or `python -m romams.persistence upgrade`)")
    return Store(engine, settings)
