"""Base of the repositories: each works inside the one Session of its unit of work and never commits."""

from __future__ import annotations

from sqlalchemy.orm import Session


class Repository:
    """Queries and writes of one aggregate on the session of the enclosing unit of work."""

    def __init__(self, session: Session) -> None:
        self._session = session
