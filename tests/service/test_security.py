"""Key scopes and hashed keys, the evaluation rate limit (in the process and in Redis), CORS, and listings that
read no model blob."""

from __future__ import annotations

import logging
import time

import numpy as np
import pytest
from fastapi.testclient import TestClient
from sqlalchemy import event
from typer.testing import CliRunner

from api.app import create_app
from romams.keys import digest, match, parse_key
from romams.settings import Settings

from .conftest import SentTasks
from .test_bad_input import problem

WRITE_KEY, READ_KEY, PLAIN_KEY = "w-" + "7" * 40, "r-" + "5" * 40, "legacy-plain-key-0123456789"
PAPER_OPTIMUM = [0.1535, 0.6135, 0.8247, 0.0203, 1.966, 0.8787, 0.5972]


def bearer(key: str) -> dict[str, str]:
    """Authorization header of a key."""
    return {"Authorization": f"Bearer {key}"}


def _hashed(key: str, scope: str) -> str:
    """The settings entry `romams keys hash` prints for a key."""
    from romams.cli import app

    out = CliRunner().invoke(app, ["keys", "hash", "--scope", scope], input=key + "\n")
    assert out.exit_code == 0, out.output
    return out.output.strip()


@pytest.fixture()
def keyed(tmp_path):
    """App with a hashed write key, a hashed read key and a plain (legacy) key."""
    entries = f"{_hashed(WRITE_KEY, 'write')},{_hashed(READ_KEY, 'read')},{PLAIN_KEY}"
    settings = Settings(data_dir=tmp_path, api_keys=entries)
    with TestClient(create_app(settings, celery=SentTasks(), sweeper=False)) as c:
        yield c, settings


def test_hashed_entries_and_the_cli():
    entry = _hashed(READ_KEY, "read")
    assert entry == f"sha256:{digest(READ_KEY)}:read" and READ_KEY not in entry
    key = parse_key(entry)
    assert key.scope == "read" and key.allows("read") and not key.allows("write")
    assert parse_key(f"sha256:{digest(WRITE_KEY)}").scope == "write" and parse_key("abc:read").scope == "read"
    assert match([key], READ_KEY) == key and match([key], READ_KEY + "x") is None
    with pytest.raises(ValueError, match="sha256"):
        parse_key("sha256:12ab")
    with pytest.raises(ValueError, match="scope"):
        parse_key(f"sha256:{digest('x')}:admin")


def test_a_read_key_reads_and_cannot_write(keyed):
    c, _ = keyed
    assert c.get("/api/v1/health").status_code == 200  # open
    problem(c.get("/api/v1/wings"), 401, "authorization")
    problem(c.get("/api/v1/jobs", headers=bearer("nope")), 403, "authorization")
    assert c.get("/api/v1/wings", headers=bearer(READ_KEY)).status_code == 200
    problem(c.post("/api/v1/wings", json={"template": "goland"}, headers=bearer(READ_KEY)), 403, "authorization",
            contains="read scope")
    assert c.post("/api/v1/wings", json={"template": "goland"}, headers=bearer(WRITE_KEY)).status_code == 201
    r = c.post("/api/v1/wings", json={"template": "cropped-delta"}, headers=bearer(PLAIN_KEY))  # legacy: write
    assert r.status_code == 201
    assert len(c.get("/api/v1/wings", headers=bearer(WRITE_KEY)).json()) == 2  # write includes read
    problem(c.post("/api/v1/jobs/x/cancel", headers=bearer(READ_KEY)), 403, "authorization")


def test_the_dashboard_needs_a_read_key(keyed):
    c, _ = keyed
    c.post("/api/v1/wings", json={"template": "goland", "name": "secret-wing"}, headers=bearer(WRITE_KEY))
    r = c.get("/dashboard")
    assert r.status_code == 401 and r.headers["www-authenticate"] == "Bearer"
    assert "secret-wing" not in r.text and 'id="key-form"' in r.text and "&quot;authorized&quot;: false" in r.text
    r = c.get("/dashboard", headers=bearer("nope"))
    assert r.status_code == 403 and "secret-wing" not in r.text
    r = c.get("/dashboard", headers=bearer(READ_KEY))
    assert r.status_code == 200 and "secret-wing" in r.text and r.headers["cache-control"] == "no-store"
    assert "img-src 'self' data: blob:" in r.headers["content-security-policy"]
    assert r.headers["x-frame-options"] == "DENY"
    assert c.get("/static/dashboard.js").status_code == 200  # the script itself is public


def test_run_and_job_pages_need_a_read_key(keyed):
    """The run and job pages hold run names, parameters and tracebacks: without a read key they are 401 pages with
    no data (common.js fetches them again with the tab's key); with one they render."""
    c, _ = keyed
    run = c.post("/api/v1/runs", json={"name": "secret-run"}, headers=bearer(WRITE_KEY)).json()["id"]
    c.post("/api/v1/wings", json={"template": "goland", "name": "secret-wing"}, headers=bearer(WRITE_KEY))
    job = c.get("/api/v1/jobs", headers=bearer(READ_KEY)).json()
    pages = [f"/dashboard/runs/{run}", "/dashboard/runs", "/dashboard/jobs"]
    pages += [f"/dashboard/jobs/{j['id']}" for j in job[:1]]
    for path in pages:
        r = c.get(path)
        assert r.status_code == 401 and r.headers["www-authenticate"] == "Bearer", path
        assert "secret" not in r.text and "&quot;authorized&quot;: false" in r.text and "<script src=\"/static/" \
            "common.js\">" in r.text, path
        assert c.get(path, headers=bearer("nope")).status_code == 403, path
        r = c.get(path, headers=bearer(READ_KEY))
        assert r.status_code == 200, path
    assert "secret-run" in c.get(f"/dashboard/runs/{run}", headers=bearer(READ_KEY)).text


def test_no_key_in_settings_repr_or_logs(tmp_path, caplog, monkeypatch):
    monkeypatch.setenv("ROMAMS_API_KEYS", f"{PLAIN_KEY},{READ_KEY}:read")
    settings = Settings(data_dir=tmp_path)
    assert [k.scope for k in settings.api_keys] == ["write", "read"]
    for text in (repr(settings), str(settings), settings.model_dump_json(), repr(settings.api_keys)):
        assert PLAIN_KEY not in text and READ_KEY not in text
    with pytest.raises(ValueError) as exc:  # a bad entry next to a plain key: the error does not show the key
        Settings(data_dir=tmp_path, api_keys=f"{PLAIN_KEY},sha256:zz")
    assert PLAIN_KEY not in str(exc.value)
    caplog.set_level(logging.DEBUG)
    with TestClient(create_app(settings, celery=SentTasks(), sweeper=False)) as c:
        c.get("/api/v1/wings", headers=bearer(READ_KEY))
        c.post("/api/v1/wings", json={"template": "goland"}, headers=bearer(READ_KEY))
        c.post("/api/v1/wings", json={"template": "goland"}, headers=bearer(PLAIN_KEY))
    assert caplog.records and not any(PLAIN_KEY in r.getMessage() or READ_KEY in r.getMessage()
                                      for r in caplog.records)


def test_keys_file(tmp_path):
    f = tmp_path / "keys"
    f.write_text(f"# operators\n{_hashed(READ_KEY, 'read')}\n\n{_hashed(WRITE_KEY, 'write')}\n")
    s = Settings(data_dir=tmp_path, api_keys=PLAIN_KEY, api_keys_file=f)
    assert [k.scope for k in s.api_keys] == ["write", "read", "write"]


def _flutter(c, headers: dict[str, str]):
    """An evaluation request the rate limit counts (to a wing that does not exist: 404 once it is let through)."""
    return c.post("/api/v1/wings/no-such-wing/flutter", json={"design": PAPER_OPTIMUM}, headers=headers)


def test_rate_limit_gives_429_with_retry_after_after_the_burst(tmp_path):
    settings = Settings(data_dir=tmp_path, api_keys=[WRITE_KEY, f"{READ_KEY}:write"], rate_limit_per_s=0.2,
                        rate_limit_burst=3)
    with TestClient(create_app(settings, celery=SentTasks(), sweeper=False)) as c:
        assert [_flutter(c, bearer(WRITE_KEY)).status_code for _ in range(3)] == [404] * 3
        body = problem(_flutter(c, bearer(WRITE_KEY)), 429, contains="rate limit")
        r = c.post("/api/v1/wings/no-such-wing/flutter/batch", json={"designs": [PAPER_OPTIMUM]},
                   headers=bearer(WRITE_KEY))
        assert r.status_code == 429 and 1 <= int(r.headers["retry-after"]) <= 5, (r.headers, body)  # 1/0.2 s
        assert _flutter(c, bearer(READ_KEY)).status_code == 404  # another key, another bucket
        assert c.get("/api/v1/jobs", headers=bearer(WRITE_KEY)).status_code == 200  # reads are not limited
        problem(_flutter(c, {}), 401)  # the key check comes first


def test_rate_limit_without_keys_is_per_client_address(tmp_path):
    # 0.5/s: a token takes 2 s to refill, so three requests on a loaded CI machine still meet an empty bucket
    settings = Settings(data_dir=tmp_path, rate_limit_per_s=0.5, rate_limit_burst=2)
    with TestClient(create_app(settings, celery=SentTasks(), sweeper=False)) as c:
        codes = [_flutter(c, {}).status_code for _ in range(3)]
        assert codes == [404, 404, 429], codes
        time.sleep(2.2)  # 0.5/s refills a token within 2 s
        assert _flutter(c, {}).status_code == 404


@pytest.mark.services
def test_rate_limit_is_shared_by_api_processes_through_redis(tmp_path, redis_url):
    """Two apps on one Redis broker (as two API processes of a deployment) draw from the same bucket."""
    settings = Settings(data_dir=tmp_path, broker_url=redis_url, api_keys=[WRITE_KEY], rate_limit_per_s=0.1,
                        rate_limit_burst=2)
    apps = [create_app(settings, celery=SentTasks(), sweeper=False) for _ in range(2)]
    with TestClient(apps[0]) as a, TestClient(apps[1]) as b:
        assert [_flutter(x, bearer(WRITE_KEY)).status_code for x in (a, b)] == [404, 404]
        r = _flutter(a, bearer(WRITE_KEY))
        assert r.status_code == 429 and 1 <= int(r.headers["retry-after"]) <= 10
        assert _flutter(b, bearer(WRITE_KEY)).status_code == 429
    import redis

    assert redis.Redis.from_url(redis_url).keys("romams:ratelimit:*")  # the bucket lives in Redis


def test_cors_is_closed_by_default_and_open_to_listed_origins(tmp_path):
    preflight = {"Origin": "https://app.example", "Access-Control-Request-Method": "POST",
                 "Access-Control-Request-Headers": "authorization,content-type"}
    with TestClient(create_app(Settings(data_dir=tmp_path / "a"), celery=SentTasks(), sweeper=False)) as c:
        r = c.options("/api/v1/wings", headers=preflight)
        assert "access-control-allow-origin" not in r.headers and r.status_code >= 400
        r = c.get("/api/v1/wings", headers={"Origin": "https://app.example"})
        assert r.status_code == 200 and "access-control-allow-origin" not in r.headers
    settings = Settings(data_dir=tmp_path / "b", cors_origins="https://app.example, https://other.example/",
                        api_keys=[READ_KEY + ":read"])
    with TestClient(create_app(settings, celery=SentTasks(), sweeper=False)) as c:
        r = c.options("/api/v1/wings", headers=preflight)  # a preflight carries no key: answered by CORS
        assert r.status_code == 200 and r.headers["access-control-allow-origin"] == "https://app.example"
        assert "authorization" in r.headers["access-control-allow-headers"].lower()
        r = c.get("/api/v1/wings", headers={"Origin": "https://other.example", **bearer(READ_KEY)})
        assert r.status_code == 200 and r.headers["access-control-allow-origin"] == "https://other.example"
        r = c.options("/api/v1/wings", headers={**preflight, "Origin": "https://evil.example"})
        assert "access-control-allow-origin" not in r.headers
        r = c.get("/api/v1/wings", headers={"Origin": "https://evil.example", **bearer(READ_KEY)})
        assert "access-control-allow-origin" not in r.headers


def test_listings_read_no_blob(tmp_path):
    """Every listing and row read selects metadata columns only; a plot (which needs the arrays) selects a blob
    (the control that shows the statements are seen)."""
    from romams_core.basis import build_basis
    from romams_core.mesh import standard_mesh
    from romams_core.wing import template

    app = create_app(Settings(data_dir=tmp_path, batch_sync_max=1), celery=SentTasks(), sweeper=False)
    store = app.state.service.store
    with TestClient(app) as c:
        wid = c.post("/api/v1/wings", json={"template": "cropped-delta"}).json()["id"]
        n = standard_mesh(template("cropped-delta").planform).n_nodes
        basis = build_basis(np.linalg.qr(np.random.default_rng(0).standard_normal((n, 2)))[0], n_modes=2)
        bid = store.bases.save(wid, basis, {"samples": 2, "modes": 2})
        store.wings.set_active_basis(wid, bid)
        store.roms.save(wid, bid, basis, {"mach": 0.87, "solver": "dlm"})  # any stored object: never loaded here
        eid = store.evaluations.save(wid, basis, summary={"mass_kg": 1.0, "results": []}, basis_id=bid)
        selects: list[str] = []

        def seen(conn, cursor, statement, *args) -> None:
            if statement.lstrip().upper().startswith("SELECT"):
                selects.append(statement)

        event.listen(store.engine, "before_cursor_execute", seen)
        try:
            for path in ("/api/v1/wings", f"/api/v1/wings/{wid}", f"/api/v1/wings/{wid}/bases",
                         f"/api/v1/wings/{wid}/roms", "/api/v1/evaluations", f"/api/v1/evaluations/{eid}",
                         "/api/v1/jobs", "/dashboard"):
                assert c.get(path).status_code == 200, path
            r = c.post(f"/api/v1/wings/{wid}/flutter/batch", json={"designs": [PAPER_OPTIMUM] * 2})
            assert r.status_code == 202, r.text  # a batch job: finds the basis and ROMs, loads none
            assert selects and not [s for s in selects if "blob" in s.lower()], [s for s in selects if "blob" in s]
            assert c.get(f"/api/v1/bases/{bid}/shapes.svg").status_code == 200
            assert any("blob" in s.lower() for s in selects)
        finally:
            event.remove(store.engine, "before_cursor_execute", seen)
