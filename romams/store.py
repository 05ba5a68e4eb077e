"""The one persistence layer shared by the CLI, the API and the workers.

``open_store()`` connects to ``ROMAMS_DATABASE_URL`` (default SQLite under ``ROMAMS_DATA_DIR``); for
SQLite it creates the data directory and brings the schema to Alembic ``head`` itself. Core result
dataclasses (Basis, TrainedRom, flutter results, ...) are stored with :mod:`romams.serialize` as JSON
meta + compressed NPZ blob. Job rows are changed only by guarded updates
(``UPDATE ... WHERE status IN (...)``) so that concurrent workers, redeliveries and cancellation
cannot overwrite a final state.
"""

from __future__ import annotations

import contextlib
import dataclasses
import fcntl
import hashlib
import json
import math
import os
import socket
import threading
import uuid
from collections.abc import Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from sqlalchemy import Engine, create_engine, event, func, select, update
from sqlalchemy.engine import make_url
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session, sessionmaker

from romams import serialize
from romams.db import ACTIVE_STATUSES, Artifact, BasisRow, Evaluation, Job, ModesUpload, RomRow, Wing, utcnow
from romams.settings import Settings, get_settings

_ENGINES: dict[str, Engine] = {}
_LOCK = threading.Lock()


def canonical_json(obj: Any) -> str:
    """Deterministic JSON text (sorted keys, no spaces) of JSON-able data, used for content keys."""
    return json.dumps(serialize.to_jsonable(obj), sort_keys=True, separators=(",", ":"))


def content_hash(*parts: Any) -> str:
    """SHA-256 hex digest of the canonical JSON of ``parts``."""
    return hashlib.sha256(canonical_json(list(parts)).encode()).hexdigest()


def rom_key(wing_id: int, basis_id: int, mach: float, params: Mapping[str, Any]) -> str:
    """Identity of a trained ROM: wing, basis, Mach (to 1e-6) and the solver/identification settings."""
    return content_hash("rom", int(wing_id), int(basis_id), round(float(mach), 6), dict(params))


def small_summary(obj: Any, max_size: int = 256) -> dict[str, Any]:
    """JSON summary of a result dataclass: scalars, strings and arrays with at most ``max_size`` entries."""
    out: dict[str, Any] = {}
    if not dataclasses.is_dataclass(obj):
        return out
    for f in dataclasses.fields(obj):
        v = getattr(obj, f.name)
        if isinstance(v, np.ndarray):
            if v.size <= max_size and v.dtype.kind in "biuf":
                out[f.name] = serialize.to_jsonable(v)
        elif isinstance(v, bool | int | float | str | np.generic) or v is None:
            out[f.name] = serialize.to_jsonable(v)
        elif isinstance(v, list | tuple) and len(v) <= max_size and all(isinstance(x, int | float | str) for x in v):
            out[f.name] = serialize.to_jsonable(list(v))
    return out


def _sqlite_pragmas(dbapi_conn: Any, _record: Any) -> None:
    """WAL journal, a generous busy timeout and foreign keys for every SQLite connection."""
    cur = dbapi_conn.cursor()
    cur.execute("PRAGMA journal_mode=WAL")
    cur.execute("PRAGMA busy_timeout=60000")
    cur.execute("PRAGMA foreign_keys=ON")
    cur.execute("PRAGMA synchronous=NORMAL")
    cur.close()


def get_engine(url: str) -> Engine:
    """Process-wide engine for ``url`` (created once)."""
    with _LOCK:
        eng = _ENGINES.get(url)
        if eng is None:
            if url.startswith("sqlite"):
                eng = create_engine(url, connect_args={"timeout": 60, "check_same_thread": False})
                event.listen(eng, "connect", _sqlite_pragmas)
            else:
                eng = create_engine(url, pool_pre_ping=True, pool_size=5, max_overflow=10)
            _ENGINES[url] = eng
        return eng


def dispose_engines() -> None:
    """Forget pooled connections (call in a forked child before first use)."""
    with _LOCK:
        for eng in _ENGINES.values():
            eng.dispose(close=False)
        _ENGINES.clear()


def migrations_dir() -> Path:
    """Directory of the Alembic scripts (works from a checkout and from an installed package)."""
    import migrations

    return Path(next(iter(migrations.__path__))).resolve()


def alembic_config(url: str) -> Any:
    """Alembic Config pointing at this package's migrations and at ``url``."""
    from alembic.config import Config

    cfg = Config()
    cfg.set_main_option("script_location", str(migrations_dir()))
    cfg.set_main_option("sqlalchemy.url", url.replace("%", "%%"))
    return cfg


def schema_revision(engine: Engine) -> str | None:
    """Alembic revision the database is at (None for an empty database)."""
    from alembic.runtime.migration import MigrationContext

    with engine.connect() as conn:
        return MigrationContext.configure(conn).get_current_revision()


def head_revision() -> str:
    """Alembic head revision of the shipped migrations."""
    from alembic.script import ScriptDirectory

    return str(ScriptDirectory.from_config(alembic_config("sqlite://")).get_current_head())


def upgrade(url: str) -> None:
    """Run ``alembic upgrade head`` programmatically on ``url``."""
    from alembic import command

    command.upgrade(alembic_config(url), "head")


def _sqlite_path(url: str) -> Path | None:
    """Filesystem path of a SQLite URL (None for in-memory)."""
    db = make_url(url).database
    return Path(db) if db and db != ":memory:" else None


def open_store(settings: Settings | None = None, *, migrate: bool | None = None) -> Store:
    """Store on the configured database; SQLite gets its directory created and is upgraded to head."""
    settings = settings or get_settings()
    url = settings.db_url
    sqlite = url.startswith("sqlite")
    if sqlite:
        path = _sqlite_path(url)
        if path is not None:
            path.parent.mkdir(parents=True, exist_ok=True)
    engine = get_engine(url)
    if migrate if migrate is not None else sqlite:
        lock_path = (_sqlite_path(url) or settings.data_dir / "romams.db").with_suffix(".migrate.lock")
        lock_path.parent.mkdir(parents=True, exist_ok=True)
        with open(lock_path, "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            if schema_revision(engine) != head_revision():
                upgrade(url)
    else:
        current = schema_revision(engine)
        if current != head_revision():
            raise RuntimeError(f"database: schema at revision {current!r}, this code needs {head_revision()!r}; "
                               "run `alembic upgrade head` (or `python -m romams.store upgrade`)")
    return Store(engine, settings)


def _iso(t: Any) -> str | None:
    """ISO-8601 UTC text of a datetime (SQLite returns naive UTC values)."""
    if t is None:
        return None
    if t.tzinfo is None:
        return t.isoformat() + "Z"
    return t.isoformat().replace("+00:00", "Z")


def job_dict(job: Job) -> dict[str, Any]:
    """API view of a job row."""
    return {
        "id": job.id,
        "kind": job.kind,
        "status": job.status,
        "progress": float(job.progress),
        "message": job.message,
        "result": job.result,
        "error": job.error,
        "params": job.params,
        "wing_id": job.wing_id,
        "parent_id": job.parent_id,
        "deliveries": job.deliveries,
        "worker": job.worker,
        "created_at": _iso(job.created_at),
        "started_at": _iso(job.started_at),
        "finished_at": _iso(job.finished_at),
        "updated_at": _iso(job.updated_at),
    }


class Store:
    """Repository of wings, bases, ROMs, jobs, evaluations and uploaded modes."""

    def __init__(self, engine: Engine, settings: Settings | None = None) -> None:
        self.engine = engine
        self.settings = settings or get_settings()
        self._sessions = sessionmaker(engine, expire_on_commit=False)

    @contextlib.contextmanager
    def session(self) -> Iterator[Session]:
        """A session committed on success and rolled back on error."""
        with self._sessions() as s:
            try:
                yield s
                s.commit()
            except BaseException:
                s.rollback()
                raise

    # ---- wings -------------------------------------------------------------------------------
    @staticmethod
    def _wing_to_json(wing: Any) -> dict[str, Any]:
        """JSON of a WingDefinition (its to_dict) or, generically, of any dataclass."""
        if hasattr(wing, "to_dict"):
            return {"format": "to-dict", "type": serialize.type_name(type(wing)),
                    "data": serialize.to_jsonable(wing.to_dict())}
        meta, _ = serialize.dumps(wing)
        if '"__ndarray__"' in json.dumps(meta):
            raise ValueError("wing: a definition without to_dict() must not hold arrays")
        return {"format": "serialized", "meta": meta}

    @staticmethod
    def _wing_from_json(d: Mapping[str, Any]) -> Any:
        """Inverse of :meth:`_wing_to_json`."""
        if d.get("format") == "to-dict":
            return serialize.resolve(d["type"]).from_dict(d["data"])
        return serialize.loads(d["meta"], serialize.dumps(None)[1])

    def create_wing(self, wing: Any, name: str | None = None) -> int:
        """Store a new wing under ``name`` (default wing.name); ValueError if the name is taken."""
        name = name or getattr(wing, "name", None)
        if not name or not isinstance(name, str) or len(name) > 200:
            raise ValueError("name: a wing name of 1..200 characters is required")
        try:
            with self.session() as s:
                row = Wing(name=name, definition=self._wing_to_json(wing))
                s.add(row)
                s.flush()
                return int(row.id)
        except IntegrityError as exc:
            raise ValueError(f"name: a wing named {name!r} already exists") from exc

    def ensure_wing(self, wing: Any, name: str | None = None) -> int:
        """Id of the wing stored under ``name`` (default wing.name), creating it if absent."""
        name = name or getattr(wing, "name", None)
        with self.session() as s:
            wid = s.scalar(select(Wing.id).where(Wing.name == name))
        if wid is not None:
            return int(wid)
        try:
            return self.create_wing(wing, name)
        except ValueError:
            with self.session() as s:
                wid = s.scalar(select(Wing.id).where(Wing.name == name))
            if wid is None:
                raise
            return int(wid)

    def find_wing(self, name_or_id: int | str) -> tuple[int, Any] | None:
        """(id, WingDefinition) by numeric id or by name, or None."""
        with self.session() as s:
            row = None
            if isinstance(name_or_id, int) or (isinstance(name_or_id, str) and name_or_id.isdigit()):
                row = s.get(Wing, int(name_or_id))
            if row is None and isinstance(name_or_id, str):
                row = s.scalar(select(Wing).where(Wing.name == name_or_id))
            if row is None:
                return None
            return int(row.id), self._wing_from_json(row.definition)

    def wing_info(self, wing_id: int) -> dict[str, Any] | None:
        """Row view of a wing: id, name, created_at and the stored definition JSON."""
        with self.session() as s:
            row = s.get(Wing, int(wing_id))
            if row is None:
                return None
            return {"id": row.id, "name": row.name, "created_at": _iso(row.created_at), "definition": row.definition}

    def list_wings(self) -> list[dict[str, Any]]:
        """All wings: id, name, created_at."""
        with self.session() as s:
            rows = s.execute(select(Wing.id, Wing.name, Wing.created_at).order_by(Wing.id)).all()
        return [{"id": r.id, "name": r.name, "created_at": _iso(r.created_at)} for r in rows]

    # ---- bases -------------------------------------------------------------------------------
    def save_basis(self, wing_id: int, basis: Any, params: Mapping[str, Any], job_id: str | None = None) -> int:
        """Store a Basis of ``wing_id`` built with ``params``; returns its id."""
        meta, blob = serialize.dumps(basis)
        n_basis = int(getattr(basis, "n_basis", 0) or 0)
        with self.session() as s:
            row = BasisRow(wing_id=int(wing_id), params=serialize.to_jsonable(dict(params)), n_basis=n_basis,
                           summary=small_summary(basis), meta=meta, blob=blob, job_id=job_id)
            s.add(row)
            s.flush()
            return int(row.id)

    def load_basis(self, basis_id: int) -> Any:
        """The Basis stored under ``basis_id`` (KeyError if absent)."""
        with self.session() as s:
            row = s.get(BasisRow, int(basis_id))
            if row is None:
                raise KeyError(f"basis {basis_id} not found")
            return serialize.loads(row.meta, row.blob)

    def latest_basis(self, wing_id: int) -> tuple[int, Any] | None:
        """(id, Basis) of the newest basis of a wing, or None."""
        with self.session() as s:
            bid = s.scalar(select(BasisRow.id).where(BasisRow.wing_id == int(wing_id)).order_by(BasisRow.id.desc()))
        return None if bid is None else (int(bid), self.load_basis(bid))

    def latest_basis_id(self, wing_id: int) -> int | None:
        """Id of the newest basis of a wing, or None."""
        with self.session() as s:
            bid = s.scalar(select(BasisRow.id).where(BasisRow.wing_id == int(wing_id)).order_by(BasisRow.id.desc()))
        return None if bid is None else int(bid)

    def active_basis_id(self, wing_id: int) -> int | None:
        """Id of the wing's active basis (None: none yet)."""
        with self.session() as s:
            bid = s.scalar(select(Wing.active_basis_id).where(Wing.id == int(wing_id)))
        return None if bid is None else int(bid)

    def set_active_basis(self, wing_id: int, basis_id: int) -> None:
        """Make ``basis_id`` (a basis of this wing) the wing's active basis; KeyError if it is not the wing's."""
        with self.session() as s:
            owner = s.scalar(select(BasisRow.wing_id).where(BasisRow.id == int(basis_id)))
            if owner != int(wing_id):
                raise KeyError(f"basis {basis_id} is not a basis of wing {wing_id}")
            s.execute(update(Wing).where(Wing.id == int(wing_id)).values(active_basis_id=int(basis_id)))

    def basis_wing_id(self, basis_id: int) -> int | None:
        """Id of the wing a basis belongs to (None: no such basis)."""
        with self.session() as s:
            wid = s.scalar(select(BasisRow.wing_id).where(BasisRow.id == int(basis_id)))
        return None if wid is None else int(wid)

    def list_bases(self, wing_id: int) -> list[dict[str, Any]]:
        """Bases of a wing (newest first): id, params, n_basis, summary (MAC table etc.)."""
        with self.session() as s:
            rows = s.scalars(select(BasisRow).where(BasisRow.wing_id == int(wing_id)).order_by(BasisRow.id.desc()))
            return [{"id": r.id, "wing_id": r.wing_id, "params": r.params, "n_basis": r.n_basis, "summary": r.summary,
                     "job_id": r.job_id, "created_at": _iso(r.created_at)} for r in rows]

    # ---- ROMs --------------------------------------------------------------------------------
    def save_rom(self, wing_id: int, basis_id: int, rom: Any, params: Mapping[str, Any],
                 job_id: str | None = None) -> int:
        """Store a TrainedRom (replacing one with the same identity); returns its id."""
        mach = float(getattr(rom, "mach", params.get("mach", math.nan)))
        if not math.isfinite(mach):
            raise ValueError("mach: the ROM must carry a finite Mach number")
        key = rom_key(wing_id, basis_id, mach, params)
        meta, blob = serialize.dumps(rom)
        summary = small_summary(rom)
        with self.session() as s:
            old = s.scalar(select(RomRow).where(RomRow.key == key))
            if old is not None:
                s.delete(old)
                s.flush()
            row = RomRow(wing_id=int(wing_id), basis_id=int(basis_id), mach=mach, solver=str(params.get("solver", "")),
                         key=key, params=serialize.to_jsonable(dict(params)), summary=summary, meta=meta, blob=blob,
                         job_id=job_id)
            s.add(row)
            s.flush()
            return int(row.id)

    def load_rom(self, rom_id: int) -> Any:
        """The TrainedRom stored under ``rom_id`` (KeyError if absent)."""
        with self.session() as s:
            row = s.get(RomRow, int(rom_id))
            if row is None:
                raise KeyError(f"rom {rom_id} not found")
            return serialize.loads(row.meta, row.blob)

    def find_rom(self, wing_id: int, basis_id: int, mach: float, params: Mapping[str, Any]) -> tuple[int, Any] | None:
        """(id, TrainedRom) trained with exactly these settings, or None."""
        key = rom_key(wing_id, basis_id, mach, params)
        with self.session() as s:
            rid = s.scalar(select(RomRow.id).where(RomRow.key == key))
        return None if rid is None else (int(rid), self.load_rom(rid))

    def find_rom_id(self, wing_id: int, basis_id: int, mach: float, params: Mapping[str, Any]) -> int | None:
        """Id of the ROM trained with exactly these settings, or None."""
        with self.session() as s:
            rid = s.scalar(select(RomRow.id).where(RomRow.key == rom_key(wing_id, basis_id, mach, params)))
        return None if rid is None else int(rid)

    def list_roms(self, wing_id: int, basis_id: int | None = None) -> list[dict[str, Any]]:
        """ROMs of a wing (optionally one basis), by Mach: id, basis_id, mach, solver, params, summary."""
        q = select(RomRow).where(RomRow.wing_id == int(wing_id))
        if basis_id is not None:
            q = q.where(RomRow.basis_id == int(basis_id))
        with self.session() as s:
            rows = s.scalars(q.order_by(RomRow.mach, RomRow.id.desc()))
            return [{"id": r.id, "wing_id": r.wing_id, "basis_id": r.basis_id, "mach": r.mach, "solver": r.solver,
                     "params": r.params, "summary": r.summary, "job_id": r.job_id, "created_at": _iso(r.created_at)}
                    for r in rows]

    # ---- evaluations -------------------------------------------------------------------------
    def save_evaluation(self, wing_id: int, result: Any, *, summary: Mapping[str, Any],
                        request: Mapping[str, Any] | None = None, basis_id: int | None = None,
                        method: str = "rom-ams", content_hash: str | None = None) -> int:
        """Store one flutter evaluation: JSON summary + full result (V-g data) as NPZ; returns its id."""
        meta, blob = serialize.dumps(result)
        with self.session() as s:
            row = Evaluation(wing_id=int(wing_id), basis_id=basis_id, method=method, content_hash=content_hash,
                             request=serialize.to_jsonable(dict(request or {})),
                             summary=serialize.to_jsonable(dict(summary)), meta=meta, blob=blob)
            s.add(row)
            s.flush()
            return int(row.id)

    def get_evaluation(self, evaluation_id: int, full: bool = False) -> dict[str, Any] | None:
        """Evaluation row as a dict (with the deserialized result under "result" when ``full``)."""
        with self.session() as s:
            r = s.get(Evaluation, int(evaluation_id))
            if r is None:
                return None
            out = {"id": r.id, "wing_id": r.wing_id, "basis_id": r.basis_id, "method": r.method,
                   "request": r.request, "summary": r.summary, "content_hash": r.content_hash,
                   "created_at": _iso(r.created_at)}
            if full:
                out["result"] = serialize.loads(r.meta, r.blob)
            return out

    def find_evaluation(self, content_hash: str) -> dict[str, Any] | None:
        """Newest evaluation stored with this content hash, or None."""
        with self.session() as s:
            eid = s.scalar(select(Evaluation.id).where(Evaluation.content_hash == content_hash)
                           .order_by(Evaluation.id.desc()))
        return None if eid is None else self.get_evaluation(eid)

    def list_evaluations(self, wing_id: int | None = None, limit: int = 20) -> list[dict[str, Any]]:
        """Newest evaluations (summary only)."""
        q = select(Evaluation)
        if wing_id is not None:
            q = q.where(Evaluation.wing_id == int(wing_id))
        with self.session() as s:
            rows = s.scalars(q.order_by(Evaluation.id.desc()).limit(int(limit)))
            return [{"id": r.id, "wing_id": r.wing_id, "basis_id": r.basis_id, "method": r.method,
                     "summary": r.summary, "created_at": _iso(r.created_at)} for r in rows]

    # ---- uploaded modes ----------------------------------------------------------------------
    def save_modes(self, modes: Any, source: str, filename: str = "", summary: Mapping[str, Any] | None = None) -> int:
        """Store external modes (any serializable object); returns the upload id."""
        meta, blob = serialize.dumps(modes)
        with self.session() as s:
            row = ModesUpload(source=source, filename=filename[:400], meta=meta, blob=blob,
                              summary=serialize.to_jsonable(dict(summary or {})))
            s.add(row)
            s.flush()
            return int(row.id)

    def load_modes(self, modes_id: int) -> Any:
        """External modes stored under ``modes_id`` (KeyError if absent)."""
        with self.session() as s:
            row = s.get(ModesUpload, int(modes_id))
            if row is None:
                raise KeyError(f"modes {modes_id} not found")
            return serialize.loads(row.meta, row.blob)

    # ---- jobs --------------------------------------------------------------------------------
    def create_job(self, kind: str, params: Mapping[str, Any], *, wing_id: int | None = None, key: str | None = None,
                   parent_id: str | None = None, job_id: str | None = None, message: str = "queued",
                   stage: str | None = None) -> str:
        """Insert a queued job row (committed before any message is sent); returns its id."""
        jid = job_id or str(uuid.uuid4())
        with self.session() as s:
            s.add(Job(id=jid, kind=kind, status="queued", progress=0.0, message=message,
                      params=serialize.to_jsonable(dict(params)), wing_id=wing_id, key=key, parent_id=parent_id,
                      deliveries=0, stage=stage, created_at=utcnow(), updated_at=utcnow()))
        return jid

    def get_job(self, job_id: str) -> dict[str, Any] | None:
        """Job row as a dict, or None."""
        with self.session() as s:
            job = s.get(Job, job_id)
            return None if job is None else job_dict(job)

    def job_status(self, job_id: str) -> str | None:
        """Just the status of a job (cheap poll), or None."""
        with self.session() as s:
            return s.scalar(select(Job.status).where(Job.id == job_id))

    def update_job(self, job_id: str, expect: Iterable[str] | None = None, **values: Any) -> bool:
        """Guarded UPDATE of a job (only when its status is in ``expect``); True if a row changed."""
        values = dict(values)
        if "result" in values and values["result"] is not None:
            values["result"] = serialize.to_jsonable(values["result"])
        values["updated_at"] = utcnow()
        q = update(Job).where(Job.id == job_id)
        if expect is not None:
            q = q.where(Job.status.in_(tuple(expect)))
        with self.session() as s:
            return s.execute(q.values(**values)).rowcount > 0

    def start_job(self, job_id: str, max_deliveries: int) -> tuple[bool, int]:
        """Mark a delivery: queued|running -> running, deliveries += 1; (ok, deliveries) with ok False when the
        job is final, absent or over the redelivery cap (then it is failed with the reason)."""
        now = utcnow()
        where = f"{socket.gethostname()}:{os.getpid()}"
        with self.session() as s:
            n = s.execute(update(Job).where(Job.id == job_id, Job.status.in_(ACTIVE_STATUSES))
                          .values(status="running", deliveries=Job.deliveries + 1, worker=where,
                                  started_at=func.coalesce(Job.started_at, now), updated_at=now)).rowcount
            deliveries = s.scalar(select(Job.deliveries).where(Job.id == job_id)) or 0
        if n == 0:
            return False, int(deliveries)
        if deliveries > max_deliveries:
            self.finish_job(job_id, "failed",
                            error=f"job delivered {deliveries} times (cap {max_deliveries}): its worker kept dying")
            return False, int(deliveries)
        return True, int(deliveries)

    def set_progress(self, job_id: str, fraction: float, message: str = "") -> bool:
        """Progress 0..1 with a message, only while running; False if the job is no longer running."""
        return self.update_job(job_id, expect=("running",), progress=float(min(max(fraction, 0.0), 1.0)),
                               message=message[:2000])

    def finish_job(self, job_id: str, status: str, result: Any = None, error: str | None = None,
                   message: str | None = None) -> bool:
        """Final transition from queued/running to succeeded/failed/cancelled (guarded)."""
        if status not in ("succeeded", "failed", "cancelled"):
            raise ValueError(f"status: {status!r} is not a final status")
        vals: dict[str, Any] = {"status": status, "finished_at": utcnow()}
        if status == "succeeded":
            vals["progress"] = 1.0
        vals["message"] = message if message is not None else status
        if result is not None:
            vals["result"] = result
        if error is not None:
            vals["error"] = error[:20000]
        return self.update_job(job_id, expect=ACTIVE_STATUSES, **vals)

    def cancel_job(self, job_id: str) -> bool:
        """Cancel a queued or running job and its active children; True if the job itself changed."""
        ok = self.finish_job(job_id, "cancelled", message="cancelled by request")
        with self.session() as s:
            children = s.scalars(select(Job.id).where(Job.parent_id == job_id, Job.status.in_(ACTIVE_STATUSES))).all()
        for c in children:
            self.finish_job(c, "cancelled", message="parent cancelled")
        return ok

    def list_jobs(self, limit: int = 50, status: str | None = None, kind: str | None = None,
                  parent_id: str | None = None, top_level: bool = False) -> list[dict[str, Any]]:
        """Newest jobs first, optionally filtered by status, kind or parent."""
        q = select(Job)
        if status:
            q = q.where(Job.status == status)
        if kind:
            q = q.where(Job.kind == kind)
        if parent_id:
            q = q.where(Job.parent_id == parent_id)
        if top_level:
            q = q.where(Job.parent_id.is_(None))
        with self.session() as s:
            return [job_dict(j) for j in s.scalars(q.order_by(Job.created_at.desc()).limit(int(limit)))]

    def children(self, parent_id: str) -> list[dict[str, Any]]:
        """Child jobs of a fan-out job, oldest first."""
        with self.session() as s:
            rows = s.scalars(select(Job).where(Job.parent_id == parent_id).order_by(Job.created_at, Job.id))
            return [job_dict(j) for j in rows]

    def claim_stage(self, job_id: str, expect: str | None, new: str) -> bool:
        """Atomically move a job's stage from ``expect`` to ``new``; True for exactly one caller."""
        q = update(Job).where(Job.id == job_id, Job.stage.is_(None) if expect is None else Job.stage == expect)
        with self.session() as s:
            return s.execute(q.values(stage=new, updated_at=utcnow())).rowcount > 0

    def heartbeat(self, job_id: str) -> bool:
        """Touch updated_at of a running job (proof of life for the stale-job sweeper)."""
        return self.update_job(job_id, expect=("running",))

    def stale_jobs(self, older_than_s: float) -> list[dict[str, Any]]:
        """Running jobs whose row has not been touched for ``older_than_s`` seconds (their worker died)."""
        import datetime as _dt

        cutoff = utcnow() - _dt.timedelta(seconds=float(older_than_s))
        if self.engine.dialect.name == "sqlite":
            cutoff = cutoff.replace(tzinfo=None)
        with self.session() as s:
            return [job_dict(j) for j in s.scalars(select(Job).where(Job.status == "running", Job.updated_at < cutoff))]

    def requeue(self, job_id: str, message: str) -> bool:
        """running -> queued (guarded), before a stale job's message is sent again."""
        return self.update_job(job_id, expect=("running",), status="queued", message=message)

    def save_artifact(self, job_id: str, name: str, obj: Any) -> None:
        """Store (or replace) a named intermediate result of a job."""
        meta, blob = serialize.dumps(obj)
        with self.session() as s:
            old = s.scalar(select(Artifact).where(Artifact.job_id == job_id, Artifact.name == name))
            if old is not None:
                s.delete(old)
                s.flush()
            s.add(Artifact(job_id=job_id, name=name, meta=meta, blob=blob))

    def load_artifact(self, job_id: str, name: str) -> Any:
        """A named intermediate result of a job (KeyError if absent)."""
        with self.session() as s:
            row = s.scalar(select(Artifact).where(Artifact.job_id == job_id, Artifact.name == name))
            if row is None:
                raise KeyError(f"artifact {name!r} of job {job_id} not found")
            return serialize.loads(row.meta, row.blob)

    def find_active_job(self, key: str) -> dict[str, Any] | None:
        """Newest queued or running job with this dedupe key, or None."""
        with self.session() as s:
            job = s.scalar(select(Job).where(Job.key == key, Job.status.in_(ACTIVE_STATUSES))
                           .order_by(Job.created_at.desc()))
            return None if job is None else job_dict(job)


def _main(argv: Sequence[str] | None = None) -> None:
    """`python -m romams.store upgrade`: bring the configured database to Alembic head."""
    import sys

    args = list(sys.argv[1:] if argv is None else argv)
    if args != ["upgrade"]:
        raise SystemExit("usage: python -m romams.store upgrade")
    upgrade(get_settings().db_url)
    print(f"database at revision {head_revision()}")


if __name__ == "__main__":
    _main()
