"""SQLAlchemy 2 typed ORM of the service: wings, bases, roms, jobs, evaluations, modes uploads.

Arrays live in compressed NPZ blobs (``blob`` columns, written by :mod:`romams.serialize`) with their
shapes and dtypes in the JSON ``meta`` column; nothing is pickled. Every ``blob`` column is deferred: a query
selects it only where it asks for it (``undefer``) or reads the attribute, so listings read metadata columns
only. Alembic (``migrations/``) owns the schema; ``Base.metadata.create_all`` is used only by tests.
Only the repositories of :mod:`romams.persistence` use these classes.
"""

from __future__ import annotations

import datetime as dt
from typing import Any

from sqlalchemy import (
    JSON,
    Boolean,
    DateTime,
    Float,
    ForeignKey,
    Index,
    Integer,
    LargeBinary,
    MetaData,
    String,
    Text,
    UniqueConstraint,
)
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column

from romams.persistence.status import JobStatus

NAMING = {
    "ix": "ix_%(column_0_label)s",
    "uq": "uq_%(table_name)s_%(column_0_name)s",
    "ck": "ck_%(table_name)s_%(constraint_name)s",
    "fk": "fk_%(table_name)s_%(column_0_name)s_%(referred_table_name)s",
    "pk": "pk_%(table_name)s",
}

def utcnow() -> dt.datetime:
    """Current time, timezone-aware UTC."""
    return dt.datetime.now(dt.UTC)


class Base(DeclarativeBase):
    """Declarative base with a stable constraint naming convention (for Alembic)."""

    metadata = MetaData(naming_convention=NAMING)
    type_annotation_map = {dict[str, Any]: JSON, list[Any]: JSON}


class Wing(Base):
    """A wing definition (planform + parametric structure), JSON from WingDefinition.to_dict()."""

    __tablename__ = "wings"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    name: Mapped[str] = mapped_column(String(200), unique=True)
    definition: Mapped[dict[str, Any]] = mapped_column(JSON)
    created_at: Mapped[dt.datetime] = mapped_column(DateTime(timezone=True), default=utcnow)
    # the basis evaluations use by default (set explicitly; the first basis of a wing becomes active)
    active_basis_id: Mapped[int | None] = mapped_column(Integer, nullable=True)


class BasisRow(Base):
    """A PCA mode-shape basis of one wing (arrays in the NPZ blob)."""

    __tablename__ = "bases"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    wing_id: Mapped[int] = mapped_column(ForeignKey("wings.id", ondelete="CASCADE"), index=True)
    params: Mapped[dict[str, Any]] = mapped_column(JSON)
    n_basis: Mapped[int] = mapped_column(Integer)
    summary: Mapped[dict[str, Any]] = mapped_column(JSON)
    meta: Mapped[dict[str, Any]] = mapped_column(JSON)
    blob: Mapped[bytes] = mapped_column(LargeBinary, deferred=True)
    job_id: Mapped[str | None] = mapped_column(String(64), nullable=True)
    created_at: Mapped[dt.datetime] = mapped_column(DateTime(timezone=True), default=utcnow)


class RomRow(Base):
    """A trained aerodynamic ROM of one wing, basis and Mach number."""

    __tablename__ = "roms"
    __table_args__ = (UniqueConstraint("key", name="uq_roms_key"),)

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    wing_id: Mapped[int] = mapped_column(ForeignKey("wings.id", ondelete="CASCADE"), index=True)
    basis_id: Mapped[int] = mapped_column(ForeignKey("bases.id", ondelete="CASCADE"), index=True)
    mach: Mapped[float] = mapped_column(Float)
    solver: Mapped[str] = mapped_column(String(50))
    key: Mapped[str] = mapped_column(String(64))
    params: Mapped[dict[str, Any]] = mapped_column(JSON)
    summary: Mapped[dict[str, Any]] = mapped_column(JSON)
    meta: Mapped[dict[str, Any]] = mapped_column(JSON)
    blob: Mapped[bytes] = mapped_column(LargeBinary, deferred=True)
    job_id: Mapped[str | None] = mapped_column(String(64), nullable=True)
    created_at: Mapped[dt.datetime] = mapped_column(DateTime(timezone=True), default=utcnow)


class Job(Base):
    """A background job; its id is the Celery task id and the row is the source of truth."""

    __tablename__ = "jobs"
    __table_args__ = (Index("ix_jobs_status_created", "status", "created_at"), Index("ix_jobs_key", "key"))

    id: Mapped[str] = mapped_column(String(64), primary_key=True)
    kind: Mapped[str] = mapped_column(String(40))
    status: Mapped[str] = mapped_column(String(20), default=JobStatus.QUEUED.value)
    progress: Mapped[float] = mapped_column(Float, default=0.0)
    message: Mapped[str] = mapped_column(Text, default="")
    params: Mapped[dict[str, Any]] = mapped_column(JSON)
    result: Mapped[dict[str, Any] | None] = mapped_column(JSON, nullable=True)
    error: Mapped[str | None] = mapped_column(Text, nullable=True)
    key: Mapped[str | None] = mapped_column(String(64), nullable=True)
    wing_id: Mapped[int | None] = mapped_column(ForeignKey("wings.id", ondelete="SET NULL"), nullable=True)
    parent_id: Mapped[str | None] = mapped_column(String(64), nullable=True, index=True)
    deliveries: Mapped[int] = mapped_column(Integer, default=0)
    stage: Mapped[str | None] = mapped_column(String(20), nullable=True)
    worker: Mapped[str | None] = mapped_column(String(200), nullable=True)  # host:pid of the last delivery
    run_id: Mapped[int | None] = mapped_column(ForeignKey("runs.id", ondelete="SET NULL"), nullable=True,
                                               index=True)  # the optimization / UQ run a batch belongs to
    traceback: Mapped[str | None] = mapped_column(Text, nullable=True)  # Python traceback of a failure
    events: Mapped[list[Any] | None] = mapped_column(JSON, nullable=True)  # [[iso time, progress, message]]
    created_at: Mapped[dt.datetime] = mapped_column(DateTime(timezone=True), default=utcnow)
    started_at: Mapped[dt.datetime | None] = mapped_column(DateTime(timezone=True), nullable=True)
    finished_at: Mapped[dt.datetime | None] = mapped_column(DateTime(timezone=True), nullable=True)
    updated_at: Mapped[dt.datetime] = mapped_column(DateTime(timezone=True), default=utcnow)


class Evaluation(Base):
    """One stored flutter evaluation (summary JSON + V-g data in the NPZ blob)."""

    __tablename__ = "evaluations"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    wing_id: Mapped[int] = mapped_column(ForeignKey("wings.id", ondelete="CASCADE"), index=True)
    basis_id: Mapped[int | None] = mapped_column(ForeignKey("bases.id", ondelete="SET NULL"), nullable=True)
    method: Mapped[str] = mapped_column(String(40))
    content_hash: Mapped[str | None] = mapped_column(String(64), nullable=True, index=True)
    request: Mapped[dict[str, Any]] = mapped_column(JSON)
    summary: Mapped[dict[str, Any]] = mapped_column(JSON)
    meta: Mapped[dict[str, Any]] = mapped_column(JSON)
    blob: Mapped[bytes] = mapped_column(LargeBinary, deferred=True)
    created_at: Mapped[dt.datetime] = mapped_column(DateTime(timezone=True), default=utcnow)


class Run(Base):
    """An optimization or UQ campaign: groups the evaluations of its batches (``settings``: feasibility rule)."""

    __tablename__ = "runs"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    name: Mapped[str] = mapped_column(String(200))
    wing_id: Mapped[int | None] = mapped_column(ForeignKey("wings.id", ondelete="SET NULL"), nullable=True)
    settings: Mapped[dict[str, Any]] = mapped_column(JSON)
    created_at: Mapped[dt.datetime] = mapped_column(DateTime(timezone=True), default=utcnow)


class RunEvaluation(Base):
    """One evaluated design of a run, compact: design vector, mass, objective, flags and per-Mach flutter rows
    (``flutter``: [[mach, flutter EAS m/s, f_f Hz, mode, safe altitude m, benchmark safe altitude m]]). Its V-g data
    are stored (as an ``evaluations`` row, ``evaluation_id``) only on request or for a new best design."""

    __tablename__ = "run_evaluations"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    run_id: Mapped[int] = mapped_column(ForeignKey("runs.id", ondelete="CASCADE"), index=True)
    job_id: Mapped[str | None] = mapped_column(String(64), nullable=True)
    x: Mapped[list[Any]] = mapped_column(JSON)
    mass_kg: Mapped[float | None] = mapped_column(Float, nullable=True)
    objective: Mapped[float | None] = mapped_column(Float, nullable=True)
    feasible: Mapped[bool] = mapped_column(Boolean)
    envelope_ok: Mapped[bool | None] = mapped_column(Boolean, nullable=True)
    min_mac: Mapped[float | None] = mapped_column(Float, nullable=True)
    flutter: Mapped[list[Any]] = mapped_column(JSON)
    error: Mapped[str | None] = mapped_column(Text, nullable=True)
    evaluation_id: Mapped[int | None] = mapped_column(ForeignKey("evaluations.id", ondelete="SET NULL"),
                                                      nullable=True)


class ModesUpload(Base):
    """External mode shapes uploaded by a client (JSON or Nastran BDF + OP2), stored as arrays."""

    __tablename__ = "modes_uploads"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    source: Mapped[str] = mapped_column(String(40))
    filename: Mapped[str] = mapped_column(String(400), default="")
    summary: Mapped[dict[str, Any]] = mapped_column(JSON)
    meta: Mapped[dict[str, Any]] = mapped_column(JSON)
    blob: Mapped[bytes] = mapped_column(LargeBinary, deferred=True)
    created_at: Mapped[dt.datetime] = mapped_column(DateTime(timezone=True), default=utcnow)


class Artifact(Base):
    """An intermediate array result of a job (e.g. one chunk's snapshots), NPZ blob + JSON meta."""

    __tablename__ = "artifacts"
    __table_args__ = (UniqueConstraint("job_id", "name", name="uq_artifacts_job_name"),)

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    job_id: Mapped[str] = mapped_column(ForeignKey("jobs.id", ondelete="CASCADE"), index=True)
    name: Mapped[str] = mapped_column(String(100))
    meta: Mapped[dict[str, Any]] = mapped_column(JSON)
    blob: Mapped[bytes] = mapped_column(LargeBinary, deferred=True)
    created_at: Mapped[dt.datetime] = mapped_column(DateTime(timezone=True), default=utcnow)
