"""Compatibility shim: ``import client`` / ``from client import ...`` re-export :mod:`romams_client`.

The client is its own distribution, ``romams-client`` (``pip install -e client/``; ``make install`` does it),
importable as ``romams_client``. This package keeps the older names working: ``client.RomamsClient``,
``client.http``, ``client.problem``, ``client.errors`` and ``client.openmdao`` are the very modules of
``romams_client`` (same classes, so isinstance checks agree). In a source checkout where ``romams-client`` is
not installed, the code next to this file is put on ``sys.path``.
"""

from __future__ import annotations

import importlib
import sys
from pathlib import Path

try:
    import romams_client
except ModuleNotFoundError:  # a source checkout without `pip install -e client/`
    sys.path.append(str(Path(__file__).resolve().parent))
    import romams_client

from romams_client import BatchEvaluation, FlutterProblem, JobError, JobTimeout, RomamsClient, RomamsError

for _name in ("errors", "http", "problem", "openmdao"):
    _mod = importlib.import_module(f"romams_client.{_name}")
    sys.modules[f"{__name__}.{_name}"] = _mod
    globals()[_name] = _mod

__all__ = ["BatchEvaluation", "FlutterProblem", "JobError", "JobTimeout", "RomamsClient", "RomamsError",
           "romams_client"]
