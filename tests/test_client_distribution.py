"""romams-client is its own distribution: httpx, numpy and tqdm only, importable without any server package."""

from __future__ import annotations

import importlib.metadata
import os
import re
import subprocess
import sys
import tomllib

import pytest
from live_service import ROOT

ALLOWED = {"httpx", "numpy", "tqdm"}
EXTRAS = {"optuna": {"optuna"}, "pymoo": {"pymoo"}, "openmdao": {"openmdao", "pydoe"}}
# server-side or heavy packages the client (without an extra) must never import
FORBIDDEN = ["romams", "romams_core", "api", "worker", "client", "scipy", "sqlalchemy", "fastapi", "celery", "psycopg",
             "redis", "matplotlib", "pydantic", "alembic", "numba", "optuna", "pymoo", "openmdao"]
CI = os.environ.get("CI", "").lower() == "true"


def _name(requirement: str) -> str:
    """Normalized project name of a PEP 508 requirement string."""
    return re.match(r"[A-Za-z0-9_.-]+", requirement.strip()).group().lower().replace("_", "-")


def test_pyproject_declares_only_httpx_numpy_tqdm() -> None:
    project = tomllib.loads((ROOT / "client/pyproject.toml").read_text())["project"]
    assert project["name"] == "romams-client"
    assert {_name(r) for r in project["dependencies"]} == ALLOWED
    extras = {k: {_name(r) for r in v} for k, v in project["optional-dependencies"].items()}
    assert extras == EXTRAS


def test_installed_distribution_requires_dist() -> None:
    try:
        meta = importlib.metadata.metadata("romams-client")
    except importlib.metadata.PackageNotFoundError:
        if CI:
            raise  # `make install` installs it
        pytest.skip("romams-client is not installed (pip install -e client/)")
    reqs = meta.get_all("Requires-Dist") or []
    base = {_name(r) for r in reqs if "extra" not in r}
    assert base == ALLOWED, reqs
    assert set(meta.get_all("Provides-Extra") or []) == set(EXTRAS)
    for extra, names in EXTRAS.items():
        assert {_name(r) for r in reqs if re.search(rf"extra\s*==\s*['\"]{extra}['\"]", r)} == names


def test_romams_client_imports_with_server_packages_blocked() -> None:
    """A fresh isolated interpreter (no PYTHONPATH, no repository root) with every forbidden package made
    unimportable imports romams_client and all its modules, and loads none of them."""
    code = f"""
import importlib.abc, sys
FORBIDDEN = {FORBIDDEN!r}
class Block(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split('.')[0] in FORBIDDEN:
            raise ImportError('blocked: ' + name)
sys.meta_path.insert(0, Block())
# the repository's own directories leave the path; the interpreter's (a .venv inside the clone) stay
sys.path[:] = [{str(ROOT / 'client')!r}] + [p for p in sys.path
                                           if p and (p.startswith(sys.prefix) or not p.startswith({str(ROOT)!r}))]
import romams_client, romams_client.http, romams_client.problem, romams_client.errors
import romams_client.openmdao, romams_client.optuna, romams_client.pymoo
assert romams_client.__file__.startswith({str(ROOT / 'client')!r}), romams_client.__file__
print(sorted({{m.split('.')[0] for m in sys.modules}} & set(FORBIDDEN)))
"""
    out = subprocess.run([sys.executable, "-I", "-c", code], cwd=ROOT / "client", capture_output=True, text=True,
                         timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"


def test_client_shim_reexports_the_same_objects() -> None:
    import client.openmdao
    import client.problem

    import client
    import romams_client
    import romams_client.openmdao

    assert client.FlutterProblem is romams_client.FlutterProblem is client.problem.FlutterProblem
    assert client.RomamsClient is romams_client.RomamsClient and client.RomamsError is romams_client.RomamsError
    assert client.openmdao is romams_client.openmdao
