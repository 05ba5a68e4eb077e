"""PCA bases of a wing: parameters and a small summary as JSON, the Basis itself as an NPZ blob."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import defer

from romams import serialize
from romams.persistence.codec import iso, small_summary
from romams.persistence.models import BasisRow
from romams.persistence.repository import Repository


class BasisRepository(Repository):
    """Save, load and list the bases of a wing."""

    def save(self, wing_id: int, basis: Any, params: Mapping[str, Any], job_id: str | None = None) -> int:
        """Store a Basis of ``wing_id`` built with ``params``; returns its id."""
        meta, blob = serialize.dumps(basis)
        n_basis = int(getattr(basis, "n_basis", 0) or 0)
        row = BasisRow(wing_id=int(wing_id), params=serialize.to_jsonable(dict(params)), n_basis=n_basis,
                       summary=small_summary(basis), meta=meta, blob=blob, job_id=job_id)
        return self._insert(row)

    def load(self, basis_id: int) -> Any:
        """The Basis stored under ``basis_id`` (KeyError if absent)."""
        return self._load_object(BasisRow, basis_id, "basis")

    def wing_id(self, basis_id: int) -> int | None:
        """Id of the wing a basis belongs to, or None if there is no such basis."""
        wid = self._session.scalar(select(BasisRow.wing_id).where(BasisRow.id == int(basis_id)))
        return None if wid is None else int(wid)

    def latest_id(self, wing_id: int) -> int | None:
        """Id of the newest basis of a wing, or None."""
        bid = self._session.scalar(select(BasisRow.id).where(BasisRow.wing_id == int(wing_id))
                                   .order_by(BasisRow.id.desc()))
        return None if bid is None else int(bid)

    def latest(self, wing_id: int) -> tuple[int, Any] | None:
        """(id, Basis) of the newest basis of a wing, or None."""
        bid = self.latest_id(wing_id)
        return None if bid is None else (bid, self.load(bid))

    def of_wing(self, wing_id: int) -> list[dict[str, Any]]:
        """Bases of a wing (newest first): id, params, n_basis, summary (MAC table etc.)."""
        rows = self._session.scalars(select(BasisRow).options(defer(BasisRow.meta), defer(BasisRow.blob))
                                     .where(BasisRow.wing_id == int(wing_id)).order_by(BasisRow.id.desc()))
        return [{"id": r.id, "wing_id": r.wing_id, "params": r.params, "n_basis": r.n_basis, "summary": r.summary,
                 "job_id": r.job_id, "created_at": iso(r.created_at)} for r in rows]
