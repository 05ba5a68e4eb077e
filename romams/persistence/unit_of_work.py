"""One unit of work: one Session, committed when the block succeeds and rolled back when it raises.

Every repository of a unit of work shares its session, so what they write together is committed
together (``with store.unit_of_work() as uow: ...``). Repositories never commit themselves.
"""

from __future__ import annotations

from types import TracebackType

from sqlalchemy.orm import Session

from romams.persistence.artifacts import ArtifactRepository
from romams.persistence.bases import BasisRepository
from romams.persistence.evaluations import EvaluationRepository
from romams.persistence.jobs import JobRepository
from romams.persistence.modes import ModesRepository
from romams.persistence.roms import RomRepository
from romams.persistence.wings import WingRepository


class UnitOfWork:
    """The repositories of one transaction; use it as a context manager (commit on success, else rollback)."""

    def __init__(self, session: Session) -> None:
        self._session = session
        self.wings = WingRepository(session)
        self.bases = BasisRepository(session)
        self.roms = RomRepository(session)
        self.evaluations = EvaluationRepository(session)
        self.modes = ModesRepository(session)
        self.jobs = JobRepository(session)
        self.artifacts = ArtifactRepository(session)

    def __enter__(self) -> UnitOfWork:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        try:
            if exc_type is None:
                self._session.commit()
            else:
                self._session.rollback()
        finally:
            self._session.close()
