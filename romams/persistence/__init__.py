"""Persistence of the service: small repositories sharing one SQLAlchemy session per unit of work.

``open_store()`` connects to ``ROMAMS_DATABASE_URL`` (default SQLite under ``ROMAMS_DATA_DIR``; SQLite is
brought to Alembic head on open). Work that belongs together runs in one unit of work::

    with store.unit_of_work() as uow:           # one session: commit on success, rollback on error
        parent = uow.jobs.create("flutter-batch", params)
        kids = [uow.jobs.create("flutter-chunk", p, parent_id=parent) for p in chunks]

and a single call can use the store's repository properties (``store.bases.load(basis_id)``), which
open a unit of work per call. Nothing outside this package imports the ORM (:mod:`.models`) or opens a
session. Result dataclasses are stored with :mod:`romams.serialize` as JSON meta + compressed NPZ blob.
"""

from __future__ import annotations

from romams.persistence.codec import canonical_json, content_hash, rom_key
from romams.persistence.engine import dispose_engines, head_revision, schema_revision, upgrade
from romams.persistence.errors import ID_MAX, ID_MIN, DatabaseUnavailable, InvalidValue, id_in_range
from romams.persistence.status import ACTIVE, FINAL, JobStatus
from romams.persistence.store import Store, open_store
from romams.persistence.unit_of_work import UnitOfWork

__all__ = ["ACTIVE", "FINAL", "ID_MAX", "ID_MIN", "DatabaseUnavailable", "InvalidValue", "JobStatus", "Store",
           "UnitOfWork", "canonical_json", "content_hash", "dispose_engines", "head_revision", "id_in_range",
           "open_store", "rom_key", "schema_revision", "upgrade"]
