"""Wings: a definition (planform + parametric structure) stored as JSON under a unique name."""

from __future__ import annotations

from typing import Any

from sqlalchemy import select, update
from sqlalchemy.exc import IntegrityError

from romams.persistence.codec import iso, wing_from_json, wing_to_json
from romams.persistence.errors import id_in_range
from romams.persistence.models import BasisRow, Wing
from romams.persistence.repository import Repository


class WingRepository(Repository):
    """Create, look up and list wings."""

    def create(self, wing: Any, name: str | None = None) -> int:
        """Store a new wing under ``name`` (default wing.name); ValueError if the name is taken."""
        name = name or getattr(wing, "name", None)
        if not name or not isinstance(name, str) or len(name) > 200:
            raise ValueError("name: a wing name of 1..200 characters is required")
        if not self._insert_unless_taken(name, wing_to_json(wing)):
            raise ValueError(f"name: a wing named {name!r} already exists")
        return int(self._session.scalar(select(Wing.id).where(Wing.name == name)))

    def ensure(self, wing: Any, name: str | None = None) -> int:
        """Id of the wing stored under ``name`` (default wing.name), creating it if absent."""
        name = name or getattr(wing, "name", None)
        wid = self.id_of(name) if isinstance(name, str) else None
        if wid is not None:
            return wid
        try:
            return self.create(wing, name)
        except ValueError:  # created meanwhile by another writer
            wid = self.id_of(name) if isinstance(name, str) else None
            if wid is None:
                raise
            return wid

    def _insert_unless_taken(self, name: str, definition: dict[str, Any]) -> bool:
        """Insert a wing row unless the name is taken (also by a concurrent writer); False if it was.

        ``INSERT ... ON CONFLICT DO NOTHING`` keeps the unit of work usable after a refused insert (a
        SAVEPOINT would do that too, but pysqlite ends its implicit transaction on RELEASE)."""
        dialect = self._session.get_bind().dialect.name
        if dialect in ("sqlite", "postgresql"):
            if dialect == "sqlite":
                from sqlalchemy.dialects.sqlite import insert
            else:
                from sqlalchemy.dialects.postgresql import insert
            stmt = (insert(Wing.__table__).values(name=name, definition=definition)
                    .on_conflict_do_nothing(index_elements=["name"]).returning(Wing.__table__.c.id))
            return self._session.execute(stmt).scalar() is not None
        if self.id_of(name) is not None:
            return False
        try:
            with self._session.begin_nested():
                self._session.add(Wing(name=name, definition=definition))
                self._session.flush()
        except IntegrityError:
            return False
        return True

    def id_of(self, name: str) -> int | None:
        """Id of the wing named ``name``, or None."""
        wid = self._session.scalar(select(Wing.id).where(Wing.name == name))
        return None if wid is None else int(wid)

    def find(self, name_or_id: int | str) -> tuple[int, Any] | None:
        """(id, WingDefinition) by numeric id or by name, or None."""
        row = None
        if isinstance(name_or_id, int) or (isinstance(name_or_id, str) and name_or_id.isascii()
                                           and name_or_id.isdigit() and len(name_or_id) <= 20):
            row = self._session.get(Wing, int(name_or_id)) if id_in_range(name_or_id) else None
        if row is None and isinstance(name_or_id, str):
            row = self._session.scalar(select(Wing).where(Wing.name == name_or_id))
        if row is None:
            return None
        return int(row.id), wing_from_json(row.definition)

    def info(self, wing_id: int) -> dict[str, Any] | None:
        """Row view of a wing: id, name, created_at and the stored definition JSON."""
        row = self._session.get(Wing, int(wing_id)) if id_in_range(wing_id) else None
        if row is None:
            return None
        return {"id": row.id, "name": row.name, "created_at": iso(row.created_at), "definition": row.definition}

    def all(self) -> list[dict[str, Any]]:
        """All wings: id, name, created_at."""
        rows = self._session.execute(select(Wing.id, Wing.name, Wing.created_at).order_by(Wing.id)).all()
        return [{"id": r.id, "name": r.name, "created_at": iso(r.created_at)} for r in rows]

    def active_basis(self, wing_id: int) -> int | None:
        """Id of the wing's active basis (the one evaluations use by default), None when it has none yet."""
        bid = self._session.scalar(select(Wing.active_basis_id).where(Wing.id == int(wing_id)))
        return None if bid is None else int(bid)

    def set_active_basis(self, wing_id: int, basis_id: int) -> None:
        """Make ``basis_id`` the wing's active basis; KeyError unless it is a basis of this wing."""
        owner = self._session.scalar(select(BasisRow.wing_id).where(BasisRow.id == int(basis_id)))
        if owner is None or int(owner) != int(wing_id):
            raise KeyError(f"basis {basis_id} is not a basis of wing {wing_id}")
        self._session.execute(update(Wing).where(Wing.id == int(wing_id)).values(active_basis_id=int(basis_id)))
