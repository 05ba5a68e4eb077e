"""External mode shapes uploaded by clients (JSON or Nastran), stored as arrays."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from romams import serialize
from romams.persistence.models import ModesUpload
from romams.persistence.repository import Repository


class ModesRepository(Repository):
    """Save and load uploaded modes."""

    def save(self, modes: Any, source: str, filename: str = "", summary: Mapping[str, Any] | None = None) -> int:
        """Store external modes (any serializable object); returns the upload id."""
        meta, blob = serialize.dumps(modes)
        row = ModesUpload(source=source, filename=filename[:400], meta=meta, blob=blob,
                          summary=serialize.to_jsonable(dict(summary or {})))
        return self._insert(row)

    def load(self, modes_id: int) -> Any:
        """External modes stored under ``modes_id`` (KeyError if absent)."""
        return self._load_object(ModesUpload, modes_id, "modes")
