"""Database engines (one per URL and process) and the Alembic helpers that keep the schema at head."""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Any

from sqlalchemy import Engine, create_engine, event
from sqlalchemy.engine import make_url

_ENGINES: dict[str, Engine] = {}
_LOCK = threading.Lock()


def _sqlite_pragmas(dbapi_conn: Any, _record: Any) -> None:
    """WAL journal, a generous busy timeout and foreign keys for every SQLite connection."""
    cur = dbapi_conn.cursor()
    cur.execute("PRAGMA journal_mode=WAL")
    cur.execute("PRAGMA busy_timeout=60000")
    cur.execute("PRAGMA foreign_keys=ON")
    cur.execute("PRAGMA synchronous=NORMAL")
    cur.close()


def get_engine(url: str, connect_timeout_s: float | None = None, pool_size: int = 44) -> Engine:
    """Process-wide engine for ``url`` (created once). Pooled server connections are pinged before use
    (``pool_pre_ping``), so a connection the server dropped (restart, outage) is replaced instead of failing the
    request; PostgreSQL connects with ``connect_timeout_s`` (an unreachable server fails fast). A server database
    keeps up to ``pool_size`` connections (opened on demand; the settings size it to the API's threads), plus
    4 overflow ones."""
    with _LOCK:
        eng = _ENGINES.get(url)
        if eng is None:
            if url.startswith("sqlite"):
                eng = create_engine(url, connect_args={"timeout": 60, "check_same_thread": False})
                event.listen(eng, "connect", _sqlite_pragmas)
            else:
                args = {"connect_timeout": max(1, int(connect_timeout_s))} if connect_timeout_s and url.startswith(
                    "postgresql") else {}
                eng = create_engine(url, pool_pre_ping=True, pool_size=pool_size, max_overflow=4, connect_args=args)
            _ENGINES[url] = eng
        return eng


def dispose_engines() -> None:
    """Forget pooled connections (call in a forked child before first use)."""
    with _LOCK:
        for eng in _ENGINES.values():
            eng.dispose(close=False)
        _ENGINES.clear()


def sqlite_path(url: str) -> Path | None:
    """Filesystem path of a SQLite URL (None for in-memory)."""
    db = make_url(url).database
    return Path(db) if db and db != ":memory:" else None


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
