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

