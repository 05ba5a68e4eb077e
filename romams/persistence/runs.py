"""Runs (optimization / UQ campaigns) and the compact evaluations of their designs.

A run's evaluations are written one chunk at a time in a single ``INSERT ... VALUES (...), (...)`` statement; each
row is small (design vector, mass, objective, flags, per-Mach flutter rows); V-g data live in an ``evaluations`` row
that a run evaluation points to only when it was asked for or the design was a new best.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from sqlalchemy import Integer, String, case, cast, func, insert, select, update

from romams import serialize
from romams.persistence.codec import iso
from romams.persistence.errors import id_in_range
from romams.persistence.models import Run, RunEvaluation
from romams.persistence.repository import Repository

#: columns of a run evaluation as the API shows it (in this order)
COLUMNS = ("id", "job_id", "x", "mass_kg", "objective", "feasible", "envelope_ok", "min_mac", "flutter", "error",
           "evaluation_id")
#: best first: feasible before infeasible, then the lowest objective, then the earliest
BEST_ORDER = (RunEvaluation.feasible.desc(), RunEvaluation.objective.asc(), RunEvaluation.id.asc())


def run_dict(r: Run) -> dict[str, Any]:
    """API view of a run row."""
    return {"id": r.id, "name": r.name, "wing_id": r.wing_id, "settings": r.settings, "created_at": iso(r.created_at)}


def evaluation_dict(r: RunEvaluation) -> dict[str, Any]:
    """API view of a run evaluation row."""
    return {c: getattr(r, c) for c in COLUMNS}


class RunRepository(Repository):
    """Create and read runs; add and read their evaluations."""

    def create(self, name: str, settings: Mapping[str, Any], wing_id: int | None = None) -> int:
        """Insert a run; its id."""
        return self._insert(Run(name=name, wing_id=wing_id, settings=serialize.to_jsonable(dict(settings))))

    def get(self, run_id: int) -> dict[str, Any] | None:
        """A run as a dict, or None."""
        r = self._session.get(Run, int(run_id)) if id_in_range(run_id) else None
        return None if r is None else run_dict(r)

    def recent(self, limit: int = 50, offset: int = 0) -> list[dict[str, Any]]:
        """Newest runs first."""
        q = select(Run).order_by(Run.id.desc()).offset(int(offset)).limit(int(limit))
        return [run_dict(r) for r in self._session.scalars(q)]

    def set_wing(self, run_id: int, wing_id: int) -> bool:
        """Give a run without a wing its wing (guarded: a run's wing never changes); True if it changed."""
        q = update(Run).where(Run.id == int(run_id), Run.wing_id.is_(None)).values(wing_id=int(wing_id))
        return self._session.execute(q).rowcount > 0

    def add_evaluations(self, run_id: int, rows: Sequence[Mapping[str, Any]]) -> int:
        """Insert the compact evaluations of one chunk in one statement; the number of rows."""
        if not rows:
            return 0
        values = [{**serialize.to_jsonable(dict(r)), "run_id": int(run_id)} for r in rows]
        self._session.execute(insert(RunEvaluation).values(values))
        return len(values)

    def evaluations(self, run_id: int, after_id: int = 0, limit: int = 1000) -> list[dict[str, Any]]:
        """Evaluations of a run in the order they were stored, those after ``after_id`` (incremental polling)."""
        q = (select(RunEvaluation).where(RunEvaluation.run_id == int(run_id), RunEvaluation.id > int(after_id))
             .order_by(RunEvaluation.id).limit(int(limit)))
        return [evaluation_dict(r) for r in self._session.scalars(q)]

    def best(self, run_id: int) -> dict[str, Any] | None:
        """The best evaluation (feasible first, lowest objective), or None."""
        r = self._session.scalar(select(RunEvaluation).where(RunEvaluation.run_id == int(run_id),
                                                              RunEvaluation.objective.is_not(None))
                                 .order_by(*BEST_ORDER).limit(1))
        return None if r is None else evaluation_dict(r)

    def best_objective(self, run_id: int) -> float | None:
        """Lowest objective of a feasible evaluation of the run (None before the first)."""
        v = self._session.scalar(select(func.min(RunEvaluation.objective))
                                 .where(RunEvaluation.run_id == int(run_id), RunEvaluation.feasible.is_(True)))
        return None if v is None else float(v)

    def counts(self, run_id: int) -> dict[str, Any]:
        """Number of evaluations, feasible, infeasible, failed (error) and with V-g data, and the stored bytes of
        their payload (design, flutter rows, error text: the JSON/text columns)."""
        e = RunEvaluation
        payload = (func.length(cast(e.x, String)) + func.length(cast(e.flutter, String))
                   + func.coalesce(func.length(e.error), 0))
        row = self._session.execute(
            select(func.count(e.id), func.sum(cast(e.feasible, Integer)),
                   func.sum(case((e.error.is_not(None), 1), else_=0)), func.count(e.evaluation_id),
                   func.sum(payload)).where(e.run_id == int(run_id))).one()
        n, feasible, failed, with_vg, payload_bytes = (int(v or 0) for v in row)
        return {"n_evaluations": n, "n_feasible": feasible, "n_infeasible": n - feasible - failed, "n_failed": failed,
                "n_with_vg": with_vg, "payload_bytes": payload_bytes}

    def table_size(self) -> tuple[int, int | None]:
        """(rows of run_evaluations, its size on disk with indexes and TOAST in bytes: PostgreSQL only, else None)."""
        rows = int(self._session.scalar(select(func.count(RunEvaluation.id))) or 0)
        if self._session.get_bind().dialect.name != "postgresql":
            return rows, None
        return rows, int(self._session.scalar(select(func.pg_total_relation_size("run_evaluations"))) or 0)
