"""The layering rule: romams_core is pure numerics and imports no service code or service library."""

import ast
import subprocess
import sys
from pathlib import Path

FORBIDDEN = {"api", "worker", "romams", "client", "romams_client", "sqlalchemy", "celery", "fastapi", "redis", "kombu",
             "matplotlib"}
CORE = Path(__file__).resolve().parents[1] / "romams_core"


def _imported_roots(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(), filename=str(path))
    roots: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            roots.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            roots.add(node.module.split(".")[0])
    return roots


def test_core_sources_import_nothing_forbidden():
    files = sorted(CORE.rglob("*.py"))
    assert files, "romams_core has no sources"
    offenders = {str(f.relative_to(CORE)): sorted(_imported_roots(f) & FORBIDDEN) for f in files}
    offenders = {k: v for k, v in offenders.items() if v}
    assert offenders == {}


def test_checker_detects_a_violation(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("import numpy\nfrom sqlalchemy.orm import Session\nimport celery.app\n")
    assert _imported_roots(bad) & FORBIDDEN == {"sqlalchemy", "celery"}


def test_importing_every_core_module_loads_no_service_library():
    mods = [
        ".".join(p.relative_to(CORE.parent).with_suffix("").parts)
        for p in CORE.rglob("*.py")
        if p.name != "__init__.py"
    ]
    code = (
        "import importlib, sys\n"
        f"for m in {mods!r}:\n    importlib.import_module(m)\n"
        f"bad = sorted(n for n in sys.modules if n.split('.')[0] in {sorted(FORBIDDEN)!r})\n"
        "print(','.join(bad))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""


def _package_graph(package: str):
    """Import graph (grimp, as used by import-linter) of one top-level package."""
    import grimp

    return grimp.build_graph(package, include_external_packages=False)


def test_worker_package_has_no_import_cycle():
    graph = _package_graph("worker")
    mods = sorted(m for m in graph.modules if m.startswith("worker"))
    cycles = [(a, b) for a in mods for b in mods
              if a < b and graph.chain_exists(a, b) and graph.chain_exists(b, a)]
    assert cycles == []


def test_cycle_check_would_see_a_cycle(tmp_path, monkeypatch):
    pkg = tmp_path / "cyc"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from cyc import b\n")
    (pkg / "b.py").write_text("from cyc import a\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    graph = _package_graph("cyc")
    assert graph.chain_exists("cyc.a", "cyc.b") and graph.chain_exists("cyc.b", "cyc.a")
