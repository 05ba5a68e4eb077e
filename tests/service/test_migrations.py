"""Alembic owns the schema: `alembic upgrade head` on empty SQLite and PostgreSQL databases gives exactly the models."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest
from sqlalchemy import create_engine, inspect

from romams.persistence import head_revision
from romams.persistence.models import Base

from .conftest import ROOT


def _alembic(args: list[str], url: str, cwd=ROOT) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if not k.startswith("ROMAMS_")}
    env["ROMAMS_DATABASE_URL"] = url
    return subprocess.run([sys.executable, "-m", "alembic", *args], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=120)


def _model_diff(url: str) -> list:
    from alembic.autogenerate import compare_metadata
    from alembic.runtime.migration import MigrationContext

    engine = create_engine(url)
    try:
        with engine.connect() as conn:
            return compare_metadata(MigrationContext.configure(conn), Base.metadata)
    finally:
        engine.dispose()


def _revision(url: str) -> str | None:
    from alembic.runtime.migration import MigrationContext

    engine = create_engine(url)
    try:
        with engine.connect() as conn:
            return MigrationContext.configure(conn).get_current_revision()
    finally:
        engine.dispose()


def _check_upgrade_downgrade(url: str) -> None:
    up = _alembic(["upgrade", "head"], url)
    assert up.returncode == 0, up.stderr
    assert _revision(url) == head_revision()
    assert _model_diff(url) == []
    tables = set(inspect(create_engine(url)).get_table_names())
    assert {"wings", "bases", "roms", "jobs", "evaluations", "modes_uploads", "artifacts"} <= tables
    down = _alembic(["downgrade", "base"], url)
    assert down.returncode == 0, down.stderr
    assert set(inspect(create_engine(url)).get_table_names()) <= {"alembic_version"}
    assert _alembic(["upgrade", "head"], url).returncode == 0 and _model_diff(url) == []


def test_sqlite_upgrade_head_matches_models(tmp_path):
    _check_upgrade_downgrade(f"sqlite:///{tmp_path / 'fresh.db'}")


def test_packaged_alembic_ini_works_from_any_directory(tmp_path):
    url = f"sqlite:///{tmp_path / 'pkg.db'}"
    import migrations

    ini = os.path.join(next(iter(migrations.__path__)), "alembic.ini")
    r = _alembic(["-c", ini, "upgrade", "head"], url, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert _revision(url) == head_revision() and _model_diff(url) == []
    env = {k: v for k, v in os.environ.items() if not k.startswith("ROMAMS_")}
    url2 = f"sqlite:///{tmp_path / 'mod.db'}"
    r = subprocess.run([sys.executable, "-m", "romams.persistence", "upgrade"], cwd=tmp_path, capture_output=True,
                       text=True, env={**env, "ROMAMS_DATABASE_URL": url2}, timeout=120)
    assert r.returncode == 0, r.stderr
    assert _revision(url2) == head_revision()


@pytest.mark.services
def test_postgres_upgrade_head_matches_models(pg_url):
    assert _revision(pg_url) is None  # a fresh, empty database
    _check_upgrade_downgrade(pg_url)


@pytest.mark.services
def test_open_store_refuses_an_unmigrated_postgres_database(pg_url, tmp_path):
    from romams.persistence import open_store
    from romams.settings import Settings

    with pytest.raises(RuntimeError, match="alembic upgrade head"):
        open_store(Settings(data_dir=tmp_path, database_url=pg_url))
    assert _alembic(["upgrade", "head"], pg_url).returncode == 0
    store = open_store(Settings(data_dir=tmp_path, database_url=pg_url))
    assert store.engine.dialect.name == "postgresql" and store.wings.all() == []
