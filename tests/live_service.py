"""The live embedded service of the client and optimization tests (benchmarks.live_service)."""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks.live_service import LiveService, free_port  # noqa: E402

__all__ = ["ROOT", "LiveService", "free_port"]
