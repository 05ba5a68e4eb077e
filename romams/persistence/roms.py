"""Trained aerodynamic ROMs, one per identity (wing, basis, Mach, solver and identification settings)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import defer

from romams import serialize
from romams.persistence.codec import iso, rom_key, small_summary
from romams.persistence.models import RomRow
from romams.persistence.repository import Repository
from romams_core.training import with_minimal_realization


class RomRepository(Repository):
    """Save (replacing the same identity), find, load and list ROMs."""

    def save(self, wing_id: int, basis_id: int, rom: Any, params: Mapping[str, Any], job_id: str | None = None) -> int:
        """Store a TrainedRom (replacing one with the same identity); returns its id."""
        mach = float(getattr(rom, "mach", params.get("mach", math.nan)))
        if not math.isfinite(mach):
            raise ValueError("mach: the ROM must carry a finite Mach number")
        key = rom_key(wing_id, basis_id, mach, params)
        meta, blob = serialize.dumps(rom)
        old = self._session.scalar(select(RomRow).where(RomRow.key == key))
        if old is not None:
            self._session.delete(old)
            self._session.flush()
        row = RomRow(wing_id=int(wing_id), basis_id=int(basis_id), mach=mach, solver=str(params.get("solver", "")),
                     key=key, params=serialize.to_jsonable(dict(params)), summary=small_summary(rom), meta=meta,
                     blob=blob, job_id=job_id)
        return self._insert(row)

    def load(self, rom_id: int) -> Any:
        """The TrainedRom stored under ``rom_id`` (KeyError if absent); an ARX ROM stored with its full realization
        comes back with its minimal one (``romams_core.training.with_minimal_realization``)."""
        return with_minimal_realization(self._load_object(RomRow, rom_id, "rom"))

    def find_id(self, wing_id: int, basis_id: int, mach: float, params: Mapping[str, Any]) -> int | None:
        """Id of the ROM trained with exactly these settings, or None."""
        rid = self._session.scalar(select(RomRow.id).where(RomRow.key == rom_key(wing_id, basis_id, mach, params)))
        return None if rid is None else int(rid)

    def find(self, wing_id: int, basis_id: int, mach: float, params: Mapping[str, Any]) -> tuple[int, Any] | None:
        """(id, TrainedRom) trained with exactly these settings, or None."""
        rid = self.find_id(wing_id, basis_id, mach, params)
        return None if rid is None else (rid, self.load(rid))

    def index(self, wing_id: int, basis_id: int) -> list[tuple[int, float, str]]:
        """(id, mach, solver) of every ROM trained on a basis of a wing, oldest first (one narrow query)."""
        rows = self._session.execute(select(RomRow.id, RomRow.mach, RomRow.solver).where(
            RomRow.wing_id == int(wing_id), RomRow.basis_id == int(basis_id)).order_by(RomRow.id))
        return [(int(r.id), float(r.mach), str(r.solver)) for r in rows]

    def of_wing(self, wing_id: int, basis_id: int | None = None) -> list[dict[str, Any]]:
        """ROMs of a wing (optionally one basis), by Mach: id, basis_id, mach, solver, params, summary."""
        q = select(RomRow).options(defer(RomRow.meta), defer(RomRow.blob)).where(RomRow.wing_id == int(wing_id))
        if basis_id is not None:
            q = q.where(RomRow.basis_id == int(basis_id))
        rows = self._session.scalars(q.order_by(RomRow.mach, RomRow.id.desc()))
        return [{"id": r.id, "wing_id": r.wing_id, "basis_id": r.basis_id, "mach": r.mach, "solver": r.solver,
                 "params": r.params, "summary": r.summary, "job_id": r.job_id, "created_at": iso(r.created_at)}
                for r in rows]
