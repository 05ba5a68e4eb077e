"""A live embedded ``romams serve`` subprocess (API + child Celery worker, SQLite, server-less broker).

Used by benchmarks.run and by the client and optimization tests: a free port, a private data dir,
settings passed as ROMAMS_* variables, nothing inherited from the caller's ROMAMS_* environment.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import httpx

ROOT = Path(__file__).resolve().parents[1]


def free_port() -> int:
    """A TCP port that is free on 127.0.0.1 right now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class LiveService:
    """``romams serve`` on 127.0.0.1:<free port> with data under ``data_dir``; use as a context manager."""

    def __init__(self, data_dir: Path, concurrency: int = 1, startup_timeout_s: float = 90.0, **settings: object
                 ) -> None:
        self.data_dir = Path(data_dir)
        self.data_dir.mkdir(parents=True, exist_ok=True)
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.log_path = self.data_dir / "serve.log"
        env = {k: v for k, v in os.environ.items() if not k.startswith("ROMAMS_")}
        env.update({"ROMAMS_DATA_DIR": str(self.data_dir), "ROMAMS_WORKER_CONCURRENCY": str(concurrency),
                    "PYTHONPATH": str(ROOT), "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1",
                    "MKL_NUM_THREADS": "1"})
        env.update({f"ROMAMS_{k.upper()}": str(v) for k, v in settings.items()})
        self._log = open(self.log_path, "ab")  # noqa: SIM115 - closed in stop()
        self.proc = subprocess.Popen(
            [sys.executable, "-c", "from romams.cli import main; main()", "serve", "--host", "127.0.0.1",
             "--port", str(self.port)],
            cwd=ROOT, env=env, stdout=self._log, stderr=subprocess.STDOUT, start_new_session=True)
        self._wait_up(startup_timeout_s)

    def _wait_up(self, timeout_s: float) -> None:
        """Poll /api/v1/health until it answers (RuntimeError with the log tail otherwise)."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                break
            try:
                if httpx.get(self.url + "/api/v1/health", timeout=2.0).status_code == 200:
                    return
            except httpx.HTTPError:
                pass
            time.sleep(0.3)
        tail = self.log_tail()
        self.stop()
        raise RuntimeError(f"romams serve did not come up on {self.url}:\n{tail}")

    def session_pids(self) -> list[int]:
        """Pids of every process of this service's session (API, worker and its pool)."""
        out = []
        for p in Path("/proc").iterdir():
            if p.name.isdigit():
                try:
                    if os.getsid(int(p.name)) == self.proc.pid:
                        out.append(int(p.name))
                except OSError:
                    continue
        return out

    def worker_pids(self) -> list[int]:
        """Pids of the Celery worker processes (main process and pool children) of this service."""
        out = []
        for pid in self.session_pids():
            try:
                cmd = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ")
            except OSError:
                continue
            if b"celery" in cmd:
                out.append(pid)
        return out

    def log_tail(self, n: int = 4000) -> str:
        """End of the service log."""
        try:
            return self.log_path.read_text(errors="replace")[-n:]
        except OSError:
            return ""

    def stop(self) -> None:
        """SIGINT to uvicorn (it stops its child worker), then SIGKILL of this session's group if it lingers."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(timeout=40)
            except subprocess.TimeoutExpired:
                pass
        try:
            os.killpg(self.proc.pid, signal.SIGKILL)  # the group of processes this object started
        except (ProcessLookupError, PermissionError):
            pass
        if self.proc.poll() is None:
            self.proc.wait(timeout=10)
        self._log.close()

    def __enter__(self) -> LiveService:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()
