"""Named intermediate results of a job (e.g. one basis chunk's snapshots), NPZ blob + JSON meta."""

from __future__ import annotations

from typing import Any

from sqlalchemy import select

from romams import serialize
from romams.persistence.models import Artifact
from romams.persistence.repository import Repository


class ArtifactRepository(Repository):
    """Save (replacing) and load a job's artifacts."""

    def save(self, job_id: str, name: str, obj: Any) -> None:
        """Store (or replace) a named intermediate result of a job."""
        meta, blob = serialize.dumps(obj)
        old = self._session.scalar(select(Artifact).where(Artifact.job_id == job_id, Artifact.name == name))
        if old is not None:
            self._session.delete(old)
            self._session.flush()
        self._session.add(Artifact(job_id=job_id, name=name, meta=meta, blob=blob))
        self._session.flush()

    def load(self, job_id: str, name: str) -> Any:
        """A named intermediate result of a job (KeyError if absent)."""
        row = self._session.scalar(select(Artifact).where(Artifact.job_id == job_id, Artifact.name == name))
        if row is None:
            raise KeyError(f"artifact {name!r} of job {job_id} not found")
        return serialize.loads(row.meta, row.blob)
