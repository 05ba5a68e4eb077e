"""Stored flutter evaluations: the request and summary as JSON, the full result (V-g data) as an NPZ blob."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from sqlalchemy import select

from romams import serialize
from romams.persistence.codec import iso
from romams.persistence.errors import id_in_range
from romams.persistence.models import Evaluation
from romams.persistence.repository import Repository


class EvaluationRepository(Repository):
    """Save, get, find by content hash and list evaluations."""

    def save(self, wing_id: int, result: Any, *, summary: Mapping[str, Any], request: Mapping[str, Any] | None = None,
             basis_id: int | None = None, method: str = "rom-ams", content_hash: str | None = None) -> int:
        """Store one flutter evaluation: JSON summary + full result (V-g data) as NPZ; returns its id."""
        meta, blob = serialize.dumps(result)
        row = Evaluation(wing_id=int(wing_id), basis_id=basis_id, method=method, content_hash=content_hash,
                         request=serialize.to_jsonable(dict(request or {})),
                         summary=serialize.to_jsonable(dict(summary)), meta=meta, blob=blob)
        return self._insert(row)

    def get(self, evaluation_id: int, full: bool = False) -> dict[str, Any] | None:
        """Evaluation row as a dict (with the deserialized result under "result" when ``full``)."""
        r = self._session.get(Evaluation, int(evaluation_id)) if id_in_range(evaluation_id) else None
        if r is None:
            return None
        out = {"id": r.id, "wing_id": r.wing_id, "basis_id": r.basis_id, "method": r.method, "request": r.request,
               "summary": r.summary, "content_hash": r.content_hash, "created_at": iso(r.created_at)}
        if full:
            out["result"] = serialize.loads(r.meta, r.blob)
        return out

    def find(self, content_hash: str) -> dict[str, Any] | None:
        """Newest evaluation stored with this content hash, or None."""
        eid = self._session.scalar(select(Evaluation.id).where(Evaluation.content_hash == content_hash)
                                   .order_by(Evaluation.id.desc()))
        return None if eid is None else self.get(eid)

    def recent(self, wing_id: int | None = None, limit: int = 20) -> list[dict[str, Any]]:
        """Newest evaluations (summary only), optionally of one wing."""
        q = select(Evaluation)
        if wing_id is not None:
            q = q.where(Evaluation.wing_id == int(wing_id))
        rows = self._session.scalars(q.order_by(Evaluation.id.desc()).limit(int(limit)))
        return [{"id": r.id, "wing_id": r.wing_id, "basis_id": r.basis_id, "method": r.method, "summary": r.summary,
                 "created_at": iso(r.created_at)} for r in rows]
