"""Only romams/persistence touches the ORM: no other source imports SQLAlchemy or the persistence internals."""

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SOURCES = ("api", "worker", "romams", "client", "benchmarks", "examples")
INTERNAL = ("sqlalchemy", "romams.persistence.models", "romams.persistence.engine", "romams.db", "romams.store")


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(), filename=str(path))
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            out.add(node.module)
    return out


def _internal(name: str) -> bool:
    return any(name == m or name.startswith(m + ".") for m in INTERNAL)


def test_nothing_outside_persistence_imports_the_orm():
    offenders = {}
    for pkg in SOURCES:
        for f in sorted((ROOT / pkg).rglob("*.py")):
            rel = f.relative_to(ROOT)
            if rel.parts[:2] == ("romams", "persistence"):
                continue
            bad = sorted(n for n in _imports(f) if _internal(n))
            if bad:
                offenders[str(rel)] = bad
    assert offenders == {}


def _session_uses(path: Path) -> list[int]:
    """Lines that reach for a session: ``x.session`` / ``x._session`` or the names Session / sessionmaker."""
    lines = []
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Attribute) and node.attr in ("session", "_session", "_sessions"):
            lines.append(node.lineno)
        elif isinstance(node, ast.Name) and node.id in ("Session", "sessionmaker"):
            lines.append(node.lineno)
    return lines


def test_no_session_is_opened_outside_persistence():
    offenders = {}
    for pkg in SOURCES:
        for f in sorted((ROOT / pkg).rglob("*.py")):
            rel = f.relative_to(ROOT)
            if rel.parts[:2] != ("romams", "persistence") and (lines := _session_uses(f)):
                offenders[str(rel)] = lines
    assert offenders == {}
