"""One unit of work: one Session, committed when the block succeeds and rolled back when it raises.

Every repository of a unit of work shares its session, so what they write together is committed
together (``with store.unit_of_work() as uow: ...``). Repositories never commit themselves. A database error
leaves the block as :class:`~romams.persistence.errors.DatabaseUnavailable` (cannot reach or use the database) or
:class:`~romams.persistence.errors.InvalidValue` (a refused value); see :mod:`romams.persistence.errors`.
"""

from __future__ import annotations

from types import TracebackType

from sqlalchemy.orm import Session

from romams.persistence.artifacts import ArtifactRepository
from romams.persistence.bases import BasisRepository
from romams.persistence.errors import translate
from romams.persistence.evaluations import EvaluationRepository
from romams.persistence.jobs import JobRepository
from romams.persistence.modes import ModesRepository
from romams.persistence.roms import RomRepository
from romams.persistence.runs import RunRepository
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
        self.runs = RunRepository(session)

    def __enter__(self) -> UnitOfWork:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        try:
            if exc_type is None:
                try:
                    self._session.commit()
                except Exception as err:
                    _rollback_quietly(self._session)
                    mapped = translate(err)
                    if mapped is None:
                        raise
                    raise mapped from err
            else:
                _rollback_quietly(self._session)
                if exc is not None and (mapped := translate(exc)) is not None:
                    raise mapped from exc
        finally:
            try:
                self._session.close()
            except Exception:  # noqa: BLE001 - closing a session on a dead connection must not mask the error
                pass


def _rollback_quietly(session: Session) -> None:
    """Roll back; on a connection that is already gone the rollback itself fails, which changes nothing."""
    try:
        session.rollback()
    except Exception:  # noqa: BLE001
        pass
