"""Throw-away Redis and PostgreSQL servers that a fault test starts, stops and restarts itself, on free ports of
their own (the machine's shared servers are never touched).

Redis runs without persistence (``--save '' --appendonly no``): a restart loses every message. PostgreSQL is a
fresh cluster (``initdb``, trust authentication) in a temporary directory, from the Debian PostgreSQL binaries
found at run time (``/usr/lib/postgresql/<version>/bin``, or ``pg_config --bindir``); as root its processes run
as the ``postgres`` user. Without the binaries the tests skip, except under ``CI=true``.
"""

from __future__ import annotations

import glob
import os
import pwd
import shutil
import socket
import subprocess
import tempfile
import time
from pathlib import Path

import pytest

from benchmarks.live_service import free_port

CI = os.environ.get("CI", "").lower() == "true"


def _missing(what: str) -> None:
    """Skip locally, fail under CI=true (where the binaries are installed)."""
    if CI:
        pytest.fail(f"{what} (CI=true: the fault tests must not skip)")
    pytest.skip(what)


def _wait_port(port: int, timeout_s: float, proc: subprocess.Popen, log: Path) -> None:
    """Wait until 127.0.0.1:``port`` accepts connections (fail with the server log if the process exits)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise RuntimeError(f"server exited ({proc.returncode}): {log.read_text(errors='replace')[-2000:]}")
        try:
            socket.create_connection(("127.0.0.1", port), timeout=0.5).close()
            return
        except OSError:
            time.sleep(0.1)
    raise RuntimeError(f"server not listening on {port} after {timeout_s} s: {log.read_text(errors='replace')[-2000:]}")


class RedisServer:
    """``redis-server`` on its own port, without persistence; stop/start keep the port (a restart)."""

    def __init__(self, workdir: Path) -> None:
        self.binary = shutil.which("redis-server")
        if self.binary is None:
            _missing("redis-server is not installed")
        self.workdir, self.port = workdir, free_port()
        self.log = workdir / "redis.log"
        self.proc: subprocess.Popen | None = None

    @property
    def url(self) -> str:
        """Broker URL of this server."""
        return f"redis://127.0.0.1:{self.port}/0"

    def start(self) -> RedisServer:
        """Start (or restart) the server: empty, since nothing was persisted."""
        with open(self.log, "ab") as log:
            self.proc = subprocess.Popen(
                [str(self.binary), "--port", str(self.port), "--bind", "127.0.0.1", "--save", "", "--appendonly",
                 "no", "--dir", str(self.workdir)], stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        _wait_port(self.port, 20, self.proc, self.log)
        return self

    def stop(self) -> None:
        """SIGKILL (a crash: nothing is saved)."""
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(timeout=10)


def postgres_bindir() -> Path | None:
    """Directory of the PostgreSQL server binaries (newest Debian version, else ``pg_config --bindir``)."""
    found = sorted(glob.glob("/usr/lib/postgresql/*/bin/initdb"), key=lambda p: int(Path(p).parts[-3])
                   if Path(p).parts[-3].isdigit() else 0)
    if found:
        return Path(found[-1]).parent
    pg_config = shutil.which("pg_config")
    if pg_config:
        out = subprocess.run([pg_config, "--bindir"], capture_output=True, text=True).stdout.strip()
        if out and (Path(out) / "initdb").exists():
            return Path(out)
    initdb = shutil.which("initdb")
    return Path(initdb).parent if initdb else None


class PostgresServer:
    """A throw-away PostgreSQL cluster (trust auth) on its own port, in a temporary directory of its own (readable
    by the ``postgres`` user when run as root); stop/start keep the data (a restart), ``remove`` deletes it."""

    def __init__(self) -> None:
        bindir = postgres_bindir()
        if bindir is None:
            _missing("PostgreSQL server binaries (initdb, postgres) not found")
        self.bindir = bindir
        self._user: list[str] = []
        owner = None
        if os.geteuid() == 0:  # initdb and postgres refuse to run as root
            try:
                owner = pwd.getpwnam("postgres")
            except KeyError:
                _missing("running as root and there is no 'postgres' user to run PostgreSQL as")
            self._user = ["runuser", "-u", "postgres", "--"]
        self.workdir, self.port = Path(tempfile.mkdtemp(prefix="romams-pg-")), free_port()
        self.data, self.log = self.workdir / "pgdata", self.workdir / "postgres.log"
        self.log.touch()
        if owner is not None:
            for p in (self.workdir, self.log):
                os.chown(p, owner.pw_uid, owner.pw_gid)
        self.proc: subprocess.Popen | None = None
        out = subprocess.run([*self._user, str(self.bindir / "initdb"), "-D", str(self.data), "-U", "postgres",
                              "-A", "trust", "--no-sync", "-E", "UTF8"], capture_output=True, text=True, timeout=120)
        if out.returncode != 0:
            self.remove()
            raise RuntimeError(f"initdb failed: {out.stderr[-2000:]}")

    def url(self, database: str = "postgres") -> str:
        """SQLAlchemy URL of ``database`` on this server."""
        return f"postgresql+psycopg://postgres@127.0.0.1:{self.port}/{database}"

    def start(self) -> PostgresServer:
        """Start (or restart) the server on its port (unix socket in the work directory, no fsync)."""
        with open(self.log, "ab") as log:
            self.proc = subprocess.Popen(
                [*self._user, str(self.bindir / "postgres"), "-D", str(self.data), "-p", str(self.port),
                 "-c", "listen_addresses=127.0.0.1", "-c", f"unix_socket_directories={self.workdir}",
                 "-c", "fsync=off", "-c", "max_connections=200"],
                stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        _wait_port(self.port, 60, self.proc, self.log)
        return self

    def stop(self) -> None:
        """Fast shutdown (SIGINT: sessions are cut, in-flight transactions rolled back)."""
        if self.proc is not None and self.proc.poll() is None:
            os.killpg(self.proc.pid, 2)
            try:
                self.proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, 9)
                self.proc.wait(timeout=10)

    def remove(self) -> None:
        """Stop the server and delete its directory."""
        self.stop()
        shutil.rmtree(self.workdir, ignore_errors=True)

    def create_database(self) -> str:
        """A fresh database; returns its URL."""
        import uuid

        import psycopg

        name = f"romams_fault_{uuid.uuid4().hex[:8]}"
        with psycopg.connect(f"postgresql://postgres@127.0.0.1:{self.port}/postgres", autocommit=True) as conn:
            conn.execute(f'CREATE DATABASE "{name}"')
        return self.url(name)
