"""Test-session setup shared by every test module."""

import os

import pytest

# one BLAS thread: the core's matrices are small and the CI machine has 2 cores (see romams/__init__.py)
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

# OpenMDAO writes HTML reports into <script>_out/ in the working directory unless told not to
os.environ.setdefault("OPENMDAO_REPORTS", "0")


@pytest.fixture()
def data_dir(tmp_path, monkeypatch):
    """A fresh local store: ROMAMS_DATA_DIR in a temporary folder (SQLite), settings cache cleared around the test."""
    from romams.settings import get_settings

    monkeypatch.setenv("ROMAMS_DATA_DIR", str(tmp_path / "data"))
    monkeypatch.delenv("ROMAMS_DATABASE_URL", raising=False)
    get_settings.cache_clear()
    yield tmp_path
    get_settings.cache_clear()


_TESTS_DIR = os.path.dirname(os.path.abspath(__file__))
_WIDER = {"module": 1, "package": 2, "session": 3}


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Tests sharing an expensive fixture (module, package or session scope, defined under tests/: a live service,
    trained ROMs) get one ``xdist_group``, so ``--dist loadgroup`` runs them on one worker and the fixture is built
    once instead of once per worker; every other test is scheduled on its own. The group is the test's module for a
    module-scoped fixture, the fixture itself for a wider one (the widest a test uses wins)."""
    import inspect

    for item in items:
        info = getattr(item, "_fixtureinfo", None)
        best: tuple[int, str] | None = None
        for name in info.names_closure if info is not None else ():
            defs = info.name2fixturedefs.get(name)
            if not defs or defs[-1].scope not in _WIDER:
                continue
            try:
                path = os.path.abspath(inspect.getfile(defs[-1].func))
            except TypeError:
                continue
            if not path.startswith(_TESTS_DIR + os.sep):
                continue  # a plugin's (tmp_path_factory, ...): cheap
            rank = _WIDER[defs[-1].scope]
            group = item.nodeid.split("::")[0] if rank == 1 else f"{os.path.relpath(path, _TESTS_DIR)}::{name}"
            if best is None or rank > best[0]:
                best = (rank, group)
        if best is not None:
            item.add_marker(pytest.mark.xdist_group(best[1]))
