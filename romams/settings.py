"""Service settings read from the environment (prefix ``ROMAMS_``), with embedded defaults.

Embedded default: everything lives under ``data_dir`` (SQLite database, SQLite-backed Celery broker),
so ``romams serve`` needs no server. Distributed: set ``ROMAMS_DATABASE_URL`` to PostgreSQL and
``ROMAMS_BROKER_URL`` to Redis, and run any number of ``romams worker`` processes.
"""

from __future__ import annotations

import os
from functools import lru_cache
from pathlib import Path
from typing import Annotated

from pydantic import Field, field_validator, model_validator
from pydantic_settings import BaseSettings, NoDecode, SettingsConfigDict

from romams.keys import ApiKey, parse_keys


class Settings(BaseSettings):
    """All service knobs; every field can be set as ``ROMAMS_<FIELD>`` in the environment."""

    model_config = SettingsConfigDict(env_prefix="ROMAMS_", extra="ignore", hide_input_in_errors=True)

    data_dir: Path = Field(default=Path(".romams"), description="directory for the SQLite db, broker and caches")
    database_url: str = Field(default="", description="SQLAlchemy URL; default sqlite:///<data_dir>/romams.db")
    broker_url: str = Field(default="", description="Celery broker; default sqla+sqlite:///<data_dir>/broker.db")
    result_backend_url: str = Field(
        default="", description="Celery result backend of synchronous evaluations; default: the Redis broker, "
        "else db+sqlite:///<data_dir>/results.db")
    result_expires_s: int = Field(default=600, ge=60, description="how long a task result is kept by the backend")
    api_keys: Annotated[list[ApiKey], NoDecode] = Field(
        default_factory=list, description="API keys, comma separated: sha256:<hex>[:read|:write] (`romams keys "
        "hash`), or plain keys (hashed when loaded); a read key opens the dashboard and every GET, a write key "
        "also the mutating endpoints; empty = no auth")
    api_keys_file: Path | None = Field(default=None, description="file of more API key entries, one a line "
                                       "(# comments); read once when the settings load")
    rate_limit_per_s: float = Field(default=0.0, ge=0, description="evaluation requests (POST .../flutter and "
                                    ".../flutter/batch) per second and key (or client address without keys); "
                                    "0 = no limit")
    rate_limit_burst: int = Field(default=0, ge=0, description="token bucket size of the rate limit (0 = "
                                  "max(1, rate_limit_per_s))")
    cors_origins: Annotated[list[str], NoDecode] = Field(
        default_factory=list, description="origins allowed to call the API from a browser (comma separated); "
        "empty = no CORS headers (browsers refuse cross-origin calls)")
    api_threads: int = Field(default=40, ge=1, description="threads of an API process for its synchronous "
                             "handlers (the concurrency the database pool is sized to)")
    malloc_arena_max: int = Field(default=2, ge=0, description="glibc malloc arenas of an API process (caps the "
                                  "memory its thread pool keeps after a burst of requests); 0 = glibc's default")
    heap_trim_s: float = Field(default=30.0, ge=0, description="period (s) at which an API process returns freed "
                               "heap pages to the kernel (malloc_trim); 0 = never")
    db_pool_size: int = Field(default=0, ge=0, description="database connections kept per process (server "
                              "databases); 0 = api_threads + 4 (the handlers, the sweeper and the heartbeat)")
    batch_sync_max: int = Field(default=64, ge=1, description="largest flutter batch answered synchronously")
    batch_max: int = Field(default=20000, ge=1, description="largest flutter batch accepted at all")
    batch_chunk: int = Field(default=64, ge=1, description="designs per evaluation task of a batch job")
    sync_timeout_s: float = Field(default=60.0, gt=0, description="how long the API waits for a synchronous result")
    max_samples: int = Field(default=500, ge=1, description="largest basis sample count")
    max_modes: int = Field(default=20, ge=1, description="largest number of modes per structure")
    basis_chunk: int = Field(default=5, ge=1, description="modal analyses per task of a basis job")
    max_deliveries: int = Field(default=3, ge=1, description="deliveries of one job before it is failed")
    training_time_limit_s: int = Field(default=3600, ge=1, description="hard time limit of a training task")
    evaluation_time_limit_s: int = Field(default=600, ge=1, description="hard time limit of an evaluation task")
    cache_size: int = Field(default=32, ge=1, description="bases/ROMs kept in a worker's memory")
    result_cache_size: int = Field(default=20000, ge=0, description="flutter results kept in a worker's memory")
    result_cache_mb: int = Field(default=64, ge=0, description="MB of flutter results (compact JSON) kept in a "
                                 "worker process's memory, whichever of this and result_cache_size is reached first")
    upload_max_bytes: int = Field(default=200_000_000, ge=1, description="largest accepted file of a modes upload "
                                  "(POST /modes); the whole multipart body may hold two such files")
    upload_inflated_max_bytes: int = Field(
        default=100_000_000, ge=1, description="largest total size of an NPZ upload's arrays once decompressed, "
        "checked from the zip directory and the .npy headers before anything is inflated")
    request_max_bytes: int = Field(default=16 * 1024 * 1024, ge=1024, description="largest request body of every "
                                   "other endpoint (413 before the body is read)")
    retry_after_s: int = Field(default=5, ge=1, description="Retry-After of a 503 (database or broker unavailable)")
    db_connect_timeout_s: int = Field(default=5, ge=1, description="PostgreSQL connect timeout: during an outage "
                                      "a request fails with 503 after at most this long")
    heartbeat_s: float = Field(default=5.0, gt=0, description="how often a running task touches its job row")
    job_stale_s: float = Field(default=60.0, gt=0, description="a running job untouched this long is re-sent")
    job_queued_resend_s: float = Field(default=300.0, gt=0, description="a queued job untouched this long is re-sent "
                                       "(its message may have been lost by a broker restart or a failed delivery)")
    broker_poll_s: float = Field(default=0.05, gt=0, description="poll period of the server-less SQLite broker")
    evaluation_poll_s: float = Field(default=0.02, gt=0, description="poll period of the SQLite broker for the "
                                     "embedded evaluation worker of `romams serve` (synchronous evaluations; "
                                     "shorter = faster answers, more idle CPU)")
    broker_visibility_timeout_s: int = Field(default=3600, ge=1, description="Redis: unacked message redelivery")
    worker_concurrency: int = Field(default_factory=lambda: max(1, min(4, os.cpu_count() or 1)), ge=1,
                                    description="processes of a worker (default: CPU cores, at most 4)")
    host: str = Field(default="127.0.0.1", description="bind address of `romams serve`")
    port: int = Field(default=8000, ge=1, le=65535, description="port of `romams serve`")

    @field_validator("api_keys", mode="before")
    @classmethod
    def _hash_keys(cls, v: object) -> object:
        """Accept a comma-separated string or a list of entries; plain keys are hashed here (only hashes stay)."""
        return parse_keys(v)

    @field_validator("cors_origins", mode="before")
    @classmethod
    def _split_origins(cls, v: object) -> object:
        """Accept a comma-separated string or a list."""
        if isinstance(v, str):
            return [o.strip().rstrip("/") for o in v.split(",") if o.strip()]
        return v

    @model_validator(mode="after")
    def _read_keys_file(self) -> Settings:
        """Append the entries of ``api_keys_file`` to ``api_keys``."""
        if self.api_keys_file is not None:
            extra = parse_keys(self.api_keys_file.read_text())
            self.api_keys = [*self.api_keys, *extra]  # type: ignore[list-item]
        return self

    @property
    def pool_size(self) -> int:
        """Database connections kept per process (``db_pool_size``, or the API's threads plus 4)."""
        return self.db_pool_size or self.api_threads + 4

    @property
    def rate_burst(self) -> int:
        """Token bucket size of the evaluation rate limit."""
        return self.rate_limit_burst or max(1, round(self.rate_limit_per_s))

    @property
    def db_url(self) -> str:
        """Effective SQLAlchemy database URL."""
        return self.database_url or f"sqlite:///{self.data_dir.resolve() / 'romams.db'}"

    @property
    def broker(self) -> str:
        """Effective Celery broker URL."""
        return self.broker_url or f"sqla+sqlite:///{self.data_dir.resolve() / 'broker.db'}"

    @property
    def is_sqlite(self) -> bool:
        """True when the database is SQLite (embedded mode)."""
        return self.db_url.startswith("sqlite")


@lru_cache(maxsize=1)
def get_settings() -> Settings:
    """Settings of this process (cached; call ``get_settings.cache_clear()`` after changing the env)."""
    return Settings()
