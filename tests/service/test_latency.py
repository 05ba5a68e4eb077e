"""Synchronous evaluations wait for their result without holding a server thread: with one handler thread
(``api_threads=1``), several evaluations wait at the same time and other requests are answered meanwhile."""

from __future__ import annotations

import threading
import time

import numpy as np
from fastapi.testclient import TestClient

from api.app import create_app
from romams.settings import Settings

WAIT_S = 1.5


def _wing_with_a_rom(app) -> int:
    """A cropped-delta wing with an active 2-shape basis and a ROM row at Mach 0.5 (never loaded: no worker runs
    the evaluations, which wait until ``sync_timeout_s`` and answer 202)."""
    from romams_core.basis import build_basis
    from romams_core.mesh import standard_mesh
    from romams_core.wing import template

    store = app.state.service.store
    wid = store.wings.ensure(template("cropped-delta"))
    n = standard_mesh(template("cropped-delta").planform).n_nodes
    basis = build_basis(np.linalg.qr(np.random.default_rng(0).standard_normal((n, 2)))[0], n_modes=2)
    bid = store.bases.save(wid, basis, {"samples": 2, "modes": 2})
    store.wings.set_active_basis(wid, bid)
    store.roms.save(wid, bid, basis, {"mach": 0.5, "solver": "dlm"})
    return wid


def test_waiting_evaluations_hold_no_thread(tmp_path):
    """Three synchronous evaluations and a batch wait together on one handler thread (with a held thread they
    would take 4 x 1.5 s one after the other), and the health check answers while they wait."""
    app = create_app(Settings(data_dir=tmp_path, sync_timeout_s=WAIT_S, api_threads=1, batch_sync_max=8),
                     sweeper=False)
    wid = _wing_with_a_rom(app)
    design = [0.3, 0.4, 0.7, 0.05, 1.0, 1.0, 0.8]
    statuses: list[int] = []
    with TestClient(app) as c:
        def post(path: str, body: dict) -> None:
            statuses.append(c.post(f"/api/v1/wings/{wid}/{path}", json=body).status_code)

        calls = [("flutter", {"design": design, "store": False})] * 3 + [("flutter/batch", {"designs": [design] * 2})]
        threads = [threading.Thread(target=post, args=call) for call in calls]
        t0 = time.monotonic()
        for t in threads:
            t.start()
        time.sleep(0.5)
        t_health = time.monotonic()
        assert c.get("/api/v1/health").status_code == 200
        health_s = time.monotonic() - t_health
        for t in threads:
            t.join(timeout=30)
        wall = time.monotonic() - t0
    assert statuses == [202] * 4, statuses  # no worker: each waited sync_timeout_s, then answered with its job
    assert health_s < 0.5 * WAIT_S, health_s
    assert WAIT_S <= wall < 2.5 * WAIT_S, wall  # together, not one after the other (>= 4 x 1.5 s)
