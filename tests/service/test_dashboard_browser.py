"""The dashboard in a real headless Chromium against `romams serve` (uvicorn + embedded child worker, SQLite)."""

from __future__ import annotations

import time

import httpx
import pytest

from benchmarks.live_service import free_port

from .browser import chromium_page

pytestmark = pytest.mark.browser


def test_dashboard_shows_a_job_reaching_100_percent(server):
    base, tmp = server
    with chromium_page(viewport={"width": 1280, "height": 900}) as (browser, page, errors):
        page.goto(f"{base}/dashboard")
        assert page.title() == "romams dashboard"
        wid = httpx.post(f"{base}/api/v1/wings", json={"template": "cropped-delta"}).json()["id"]
        r = httpx.post(f"{base}/api/v1/wings/{wid}/basis", json={"samples": 60, "modes": 3})
        assert r.status_code == 202, (r.text, (tmp / "serve.log").read_text()[-3000:])
        job_id = r.json()["job_id"]
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
    server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=free_port(), log_level="warning"))
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
    base, keys = keyed_server
    with chromium_page() as (browser, page, errors):
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
