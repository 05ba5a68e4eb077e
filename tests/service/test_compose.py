"""The deployment files name real services, modules, entry points and settings (no Docker engine needed)."""

from __future__ import annotations

import importlib
import re
import tomllib

import yaml

from romams.settings import Settings

from .conftest import ROOT

TEXT = (ROOT / "docker-compose.yml").read_text()
COMPOSE = yaml.safe_load(TEXT)
SERVICES = COMPOSE["services"]
WORKERS = ("worker-training", "worker-evaluation")


def _queues(service: str) -> set[str]:
    """Queues a worker service consumes (its ``--queues`` argument)."""
    cmd = SERVICES[service]["command"]
    return set(cmd[cmd.index("--queues") + 1].split(","))


def test_services_and_dependencies():
    assert {"redis", "postgres", "migrate", "api", *WORKERS, "flower"} <= set(SERVICES)
    for name in ("redis", "postgres", "api", *WORKERS):
        assert "test" in SERVICES[name]["healthcheck"], name
    api_deps = SERVICES["api"]["depends_on"]
    assert api_deps["migrate"]["condition"] == "service_completed_successfully"
    assert api_deps["redis"]["condition"] == "service_healthy"
    assert SERVICES["migrate"]["depends_on"]["postgres"]["condition"] == "service_healthy"
    for w in WORKERS:
        assert SERVICES[w]["depends_on"]["migrate"]["condition"] == "service_completed_successfully", w
        assert SERVICES[w]["depends_on"]["redis"]["condition"] == "service_healthy", w
        assert "ports" not in SERVICES[w] and "container_name" not in SERVICES[w], w  # scalable
    assert SERVICES["api"]["ports"] == ["8000:8000"]


def test_safe_deployment_defaults():
    """No default API key (compose refuses to start without one), Flower on loopback only, restart policies,
    evaluation workers apart from training workers, Redis with its append-only file."""
    key = r"\$\{ROMAMS_API_KEY:\?[^}]+\}"  # ${VAR:?message}: an unset or empty variable stops `docker compose up`
    for name, svc in SERVICES.items():
        value = (svc.get("environment") or {}).get("ROMAMS_API_KEYS")
        if value is not None:
            assert re.fullmatch(key, value), (name, value)
    assert "change-me" not in TEXT and ":-change" not in TEXT
    flower = SERVICES["flower"]
    assert all(str(p).startswith("127.0.0.1:") for p in flower["ports"]) or any(
        a.startswith("--basic-auth") for a in flower["command"]), flower
    for name in ("api", *WORKERS):
        assert SERVICES[name]["restart"] == "unless-stopped", name
    assert _queues("worker-training") == {"training"} and _queues("worker-evaluation") == {"evaluation"}
    assert not any("evaluation" in _queues(w) and "training" in _queues(w) for w in WORKERS)
    from worker.celery_app import app as celery

    assert _queues("worker-training") | _queues("worker-evaluation") == {q.name for q in celery.conf.task_queues}
    assert SERVICES["redis"]["command"][-2:] == ["--appendonly", "yes"]


def test_commands_name_real_code():
    assert SERVICES["migrate"]["command"] == ["alembic", "upgrade", "head"]
    assert (ROOT / "alembic.ini").exists() and (ROOT / "migrations" / "env.py").exists()
    api_cmd = SERVICES["api"]["command"]
    assert api_cmd[0] == "uvicorn"
    module, attr = api_cmd[1].split(":")
    assert callable(importlib.import_module(module).create_app) and attr == "app"
    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    from romams.cli import app

    assert "worker" in {c.name or c.callback.__name__ for c in app.registered_commands}
    for w in WORKERS:
        worker_cmd = SERVICES[w]["command"]
        assert worker_cmd[0] in scripts and worker_cmd[1] == "worker", w
    flower = SERVICES["flower"]["command"]
    assert flower[:3] == ["celery", "-A", "worker.celery_app"] and "flower" in flower
    importlib.import_module(flower[2])
    dockerfile = (ROOT / "Dockerfile").read_text()
    assert "uvicorn\", \"api.app:app\"" in dockerfile and "COPY migrations" in dockerfile
    # the image compiles the tracker's numba kernels into a cache its user can read (the function exists)
    assert "from romams_core.flutter.newton_kernel import warm_up; warm_up()" in dockerfile
    assert "ENV NUMBA_CACHE_DIR=" in dockerfile.split("USER romams")[1]
    assert callable(importlib.import_module("romams_core.flutter.newton_kernel").warm_up)


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


def test_api_pool_fits_postgresql_max_connections():
    """The API processes' database pools (api_threads + 4, plus 4 overflow each) and the workers stay within
    PostgreSQL's default max_connections (100)."""
    api = SERVICES["api"]
    env = api["environment"]
    processes = int(api["command"][api["command"].index("--workers") + 1])
    s = Settings(**{k.removeprefix("ROMAMS_").lower(): v for k, v in env.items()})
    workers = sum(int(SERVICES[w]["environment"].get("ROMAMS_WORKER_CONCURRENCY", 1)) + 1 for w in WORKERS)
    assert processes * (s.pool_size + 4) + 2 * workers <= 100, (processes, s.pool_size, workers)
