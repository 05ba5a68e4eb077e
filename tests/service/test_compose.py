"""The deployment files name real services, modules, entry points and settings (no Docker engine needed)."""

from __future__ import annotations

import importlib
import re
import tomllib

import yaml

from romams.settings import Settings

from .conftest import ROOT

COMPOSE = yaml.safe_load((ROOT / "docker-compose.yml").read_text())
SERVICES = COMPOSE["services"]


def test_services_and_dependencies():
    assert {"redis", "postgres", "migrate", "api", "worker", "flower"} <= set(SERVICES)
    for name in ("redis", "postgres", "api", "worker"):
        assert "test" in SERVICES[name]["healthcheck"], name
    api_deps = SERVICES["api"]["depends_on"]
    assert api_deps["migrate"]["condition"] == "service_completed_successfully"
    assert api_deps["redis"]["condition"] == "service_healthy"
    assert SERVICES["migrate"]["depends_on"]["postgres"]["condition"] == "service_healthy"
    assert SERVICES["worker"]["depends_on"]["migrate"]["condition"] == "service_completed_successfully"
    assert "ports" not in SERVICES["worker"] and "container_name" not in SERVICES["worker"]  # scalable
    assert SERVICES["api"]["ports"] == ["8000:8000"] and SERVICES["flower"]["ports"] == ["5555:5555"]


def test_commands_name_real_code():
    assert SERVICES["migrate"]["command"] == ["alembic", "upgrade", "head"]
    assert (ROOT / "alembic.ini").exists() and (ROOT / "migrations" / "env.py").exists()
    api_cmd = SERVICES["api"]["command"]
    assert api_cmd[0] == "uvicorn"
    module, attr = api_cmd[1].split(":")
    assert callable(importlib.import_module(module).create_app) and attr == "app"
    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    worker_cmd = SERVICES["worker"]["command"]
    assert worker_cmd[0] in scripts and worker_cmd[1] == "worker"
    from romams.cli import app

    assert "worker" in {c.name or c.callback.__name__ for c in app.registered_commands}
    queues = worker_cmd[worker_cmd.index("--queues") + 1].split(",")
    from worker.celery_app import app as celery

    assert set(queues) == {q.name for q in celery.conf.task_queues}
    flower = SERVICES["flower"]["command"]
    assert flower[:3] == ["celery", "-A", "worker.celery_app"] and "flower" in flower
    importlib.import_module(flower[2])
    dockerfile = (ROOT / "Dockerfile").read_text()
    assert "uvicorn\", \"api.app:app\"" in dockerfile and "COPY migrations" in dockerfile


def test_environment_variables_are_settings_fields():
    fields = set(Settings.model_fields)
    for name, svc in SERVICES.items():
        env = svc.get("environment") or {}
        if name in ("redis", "postgres"):
            continue
        keys = [k for k in env if k.startswith("ROMAMS_")]
        assert keys, name
        for k in keys:
            assert k.removeprefix("ROMAMS_").lower() in fields, (name, k)
        assert env["ROMAMS_DATABASE_URL"].startswith("postgresql+psycopg://")
        assert env["ROMAMS_BROKER_URL"].startswith("redis://redis:6379")
        assert env["ROMAMS_API_KEYS"]
        s = Settings(**{k.removeprefix("ROMAMS_").lower(): v for k, v in env.items()})  # values parse
        assert s.db_url == env["ROMAMS_DATABASE_URL"] and s.api_keys
    pg = SERVICES["postgres"]["environment"]
    url = SERVICES["api"]["environment"]["ROMAMS_DATABASE_URL"]
    m = re.match(r"postgresql\+psycopg://(\w+):(\w+)@postgres:5432/(\w+)", url)
    assert m and m.groups() == (pg["POSTGRES_USER"], pg["POSTGRES_PASSWORD"], pg["POSTGRES_DB"])
