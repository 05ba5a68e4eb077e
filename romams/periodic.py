"""A daemon thread calling a function every ``period_s`` seconds (the stale-job sweeper, a job's heartbeat, the
API's heap trimmer)."""

from __future__ import annotations

import threading
from collections.abc import Callable


class Periodic:
    """Calls ``fn()`` every ``period_s`` seconds in a daemon thread until :meth:`stop` or until ``fn`` returns
    False; an exception of ``fn`` (e.g. a transient database error) does not end the thread."""

    def __init__(self, fn: Callable[[], bool | None], period_s: float, name: str) -> None:
        self.fn, self.period_s = fn, period_s
        self._stop = threading.Event()
        self._t = threading.Thread(target=self._run, daemon=True, name=name)

    def _run(self) -> None:
        while not self._stop.wait(self.period_s):
            try:
                if self.fn() is False:
                    return
            except Exception:  # noqa: BLE001 - keep going after a transient error
                continue

    def start(self) -> Periodic:
        self._t.start()
        return self

    def stop(self, join_s: float = 0.0) -> None:
        """Ask the thread to end; wait up to ``join_s`` seconds for it."""
        self._stop.set()
        if join_s > 0:
            self._t.join(timeout=join_s)
