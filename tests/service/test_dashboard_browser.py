"""The dashboard in a real headless Chromium against `romams serve` (uvicorn + embedded child worker, SQLite)."""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import httpx
import pytest

from .conftest import CI, ROOT, service_env

pytestmark = pytest.mark.browser
CHROMIUM = "/usr/bin/chromium"


def _chromium() -> str:
    """Path of the system Chromium, installing it with apt-get if absent."""
    if not Path(CHROMIUM).exists() and shutil.which("apt-get"):
        # a fresh machine may have no package lists yet: update once, then install
        subprocess.run(["apt-get", "update"], capture_output=True, timeout=600)
        subprocess.run(["apt-get", "install", "-y", "chromium"], capture_output=True, timeout=900)
    if not Path(CHROMIUM).exists():
        if CI:
            pytest.fail("Chromium is not installed at /usr/bin/chromium")
        pytest.skip("Chromium is not installed at /usr/bin/chromium")
    return CHROMIUM


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture()
def server(tmp_path):
    port = _free_port()
    env = service_env(tmp_path / "data", port=port, heartbeat_s=0.5)
    log = open(tmp_path / "serve.log", "wb")  # noqa: SIM115
    cmd = [sys.executable, "-c", "from romams.cli import main; main()", "serve", "--loglevel", "info"]
    proc = subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    base = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 60
    while True:
        try:
            if httpx.get(f"{base}/api/v1/health", timeout=2).status_code == 200:
                break
        except httpx.HTTPError:
            pass
        if proc.poll() is not None or time.monotonic() > deadline:
            raise AssertionError((tmp_path / "serve.log").read_text()[-3000:])
        time.sleep(0.3)
    children = Path(f"/proc/{proc.pid}/task/{proc.pid}/children")
    worker_pids = [int(p) for p in children.read_text().split()]
    assert len(worker_pids) == 2, "romams serve starts a training and an evaluation worker"
    try:
        yield base, tmp_path
    finally:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=40)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
        log.close()
        deadline = time.monotonic() + 60  # the embedded worker goes with the server (warm shutdown)
        while any(Path(f"/proc/{p}").exists() and "zombie" not in _state(p) for p in worker_pids):
            if time.monotonic() > deadline:
                os.killpg(proc.pid, signal.SIGKILL)
                raise AssertionError("the embedded worker outlived `romams serve`")
            time.sleep(0.2)


def _state(pid: int) -> str:
    """Process state line from /proc (empty if gone)."""
    try:
        return next(line for line in Path(f"/proc/{pid}/status").read_text().splitlines() if line.startswith("State"))
    except (OSError, StopIteration):
        return "zombie"


def test_dashboard_shows_a_job_reaching_100_percent(server):
    from playwright.sync_api import sync_playwright

    base, tmp = server
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=_chromium(), headless=True,
                                     args=["--headless", "--no-sandbox", "--disable-gpu",
                                           "--disable-background-networking"])
        try:
            page = browser.new_page(viewport={"width": 1280, "height": 900})
            errors: list[str] = []
            page.on("pageerror", lambda exc: errors.append(str(exc)))
            page.goto(f"{base}/dashboard")
            assert page.title() == "romams dashboard"
            wid = httpx.post(f"{base}/api/v1/wings", json={"template": "cropped-delta"}).json()["id"]
            job_id = httpx.post(f"{base}/api/v1/wings/{wid}/basis", json={"samples": 60, "modes": 3}).json()["job_id"]
            row = f'tr[data-job="{job_id}"]'
            page.wait_for_selector(row, timeout=15_000)  # the poller shows the new job without a reload
            seen = set()
            deadline = time.monotonic() + 240
            while time.monotonic() < deadline:
                pct = page.text_content(f"{row} .pct")
                seen.add(pct)
                if pct == "100%":
                    break
                time.sleep(0.2)
            assert page.text_content(f"{row} .pct") == "100%", (seen, (tmp / "serve.log").read_text()[-3000:])
            page.wait_for_function(f"document.querySelector('{row} .st').textContent === 'succeeded'",
                                   timeout=10_000)
            width = page.eval_on_selector(f"{row} .fill", "e => e.style.width")
            assert width == "100%"
            assert len(seen) >= 2, seen  # it moved while we watched (0% ... 100%)
            # finished work refreshes the wings section: the new basis and its MAC table appear
            page.wait_for_selector("section.wing .basis table.mac", timeout=15_000)
            assert "cropped-delta" in page.text_content("#wings-section")
            page.screenshot(path=str(tmp / "dashboard.png"), full_page=True)
            assert not errors, errors
        finally:
            browser.close()


@pytest.fixture()
def keyed_server(tmp_path):
    """The API alone (uvicorn in a thread, no worker) with a read and a write key; a wing with a basis."""
    import threading

    import numpy as np
    import uvicorn

    from api.app import create_app
    from romams.keys import digest
    from romams.settings import Settings
    from romams_core.basis import build_basis
    from romams_core.mesh import standard_mesh
    from romams_core.wing import template

    keys = {"read": "dash-read-" + "1" * 30, "write": "dash-write-" + "2" * 30}
    app = create_app(Settings(data_dir=tmp_path, api_keys=[f"sha256:{digest(k)}:{s}" for s, k in keys.items()]),
                     sweeper=False)
    store = app.state.service.store
    wid = store.wings.ensure(template("cropped-delta"))
    n = standard_mesh(template("cropped-delta").planform).n_nodes
    basis = build_basis(np.linalg.qr(np.random.default_rng(0).standard_normal((n, 2)))[0], n_modes=2)
    store.wings.set_active_basis(wid, store.bases.save(wid, basis, {"samples": 2, "modes": 2}))
    server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=_free_port(), log_level="warning"))
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    deadline = time.monotonic() + 30
    while not server.started:
        assert time.monotonic() < deadline and thread.is_alive(), "uvicorn did not start"
        time.sleep(0.05)
    try:
        yield f"http://127.0.0.1:{server.config.port}", keys
    finally:
        server.should_exit = True
        thread.join(timeout=10)


def test_dashboard_with_keys_asks_for_one_and_sends_it(keyed_server):
    """Keys configured: the page comes without data; a key in the URL fragment (then removed from the address) or
    typed into the form is kept in sessionStorage and sent with every fetch, plots included (blob: URLs)."""
    from playwright.sync_api import sync_playwright

    base, keys = keyed_server
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=_chromium(), headless=True,
                                     args=["--headless", "--no-sandbox", "--disable-gpu",
                                           "--disable-background-networking"])
        try:
            page = browser.new_page()
            errors: list[str] = []
            page.on("pageerror", lambda exc: errors.append(str(exc)))
            page.goto(f"{base}/dashboard#key={keys['read']}")
            page.wait_for_selector("section.wing .basis table.mac", timeout=15_000)
            assert "cropped-delta" in page.text_content("#wings-section") and "#key" not in page.url
            # CSS and text selectors only: a string predicate would be an eval, which the CSP forbids
            page.wait_for_selector('img.shapes[src^="blob:"]', timeout=15_000)
            page.wait_for_selector('#poll-state:has-text("updated")', timeout=10_000)
            assert page.is_hidden("#key-form")
            page.reload()  # the key stays for this tab
            page.wait_for_selector("section.wing .basis table.mac", timeout=15_000)

            other = browser.new_page()  # a new tab: no key yet
            other.goto(f"{base}/dashboard")
            other.wait_for_selector("#key-form", state="visible", timeout=10_000)
            assert "cropped-delta" not in other.text_content("#wings-section")
            other.fill("#key-input", "not-a-key")
            other.click("#key-form button")
            other.wait_for_selector('#key-error:has-text("403")', timeout=10_000)
            other.fill("#key-input", keys["read"])
            other.click("#key-form button")
            other.wait_for_selector("section.wing .basis table.mac", timeout=15_000)
            assert not errors, errors
        finally:
            browser.close()
