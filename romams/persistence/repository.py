"""Base of the repositories: each works inside the one Session of its unit of work and never commits."""

from __future__ import annotations

from typing import Any

from sqlalchemy.orm import Session, undefer

from romams import serialize
from romams.persistence.errors import id_in_range


class Repository:
    """Queries and writes of one aggregate on the session of the enclosing unit of work."""

    def __init__(self, session: Session) -> None:
        self._session = session

    def _insert(self, row: Any) -> int:
        """Add ``row`` and flush it; its new id."""
        self._session.add(row)
        self._session.flush()
        return int(row.id)

    def _load_object(self, model: Any, row_id: int, what: str) -> Any:
        """The core object stored (meta + NPZ blob) in the ``model`` row ``row_id``; KeyError naming ``what``."""
        row = self._session.get(model, int(row_id), options=[undefer(model.blob)]) if id_in_range(row_id) else None
        if row is None:
            raise KeyError(f"{what} {row_id} not found")
        return serialize.loads(row.meta, row.blob)
