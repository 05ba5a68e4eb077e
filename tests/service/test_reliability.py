"""Reliability and security of the API: strict input, bounded bodies and uploads, 503 during a database outage,
security headers (cancel atomic with the stored model: test_cancel_atomic.py).

The input cases run on SQLite and (``services``) on PostgreSQL, where the database matters (ids beyond its integer
range, NUL characters). No worker process: validation and the limits act before anything is queued.
"""

from __future__ import annotations

import io
import json
import socket
import threading
import tracemalloc
import zipfile
from urllib.parse import urlsplit, urlunsplit

import numpy as np
import pytest
from fastapi.testclient import TestClient

from api.app import create_app
from romams.persistence import open_store
from romams.settings import Settings

from .conftest import BACKENDS, SentTasks, backend_settings
from .test_bad_input import problem


@pytest.fixture(params=BACKENDS)
def client(request, tmp_path):
    app = create_app(backend_settings(request, tmp_path, max_samples=50), celery=SentTasks(), sweeper=False)
    with TestClient(app) as c:
        yield c


def _rows(c) -> tuple:
    jobs = c.get("/api/v1/jobs", params={"limit": 1000, "include_children": True}).json()
    return len(c.get("/api/v1/wings").json()), len(jobs), len(c.get("/api/v1/evaluations").json())


# ---- strict input ---------------------------------------------------------------------------------------------
def test_ids_beyond_the_database_integer_range_are_404_in_paths_and_422_in_queries_and_bodies(client):
    wid = client.post("/api/v1/wings", json={"template": "cropped-delta"}).json()["id"]
    before = _rows(client)
    for big in (2**31, 2**40, 2**63 - 1, 2**63, 2**64, 2**70, 10**30):
        for url, field in ((f"/api/v1/wings/{big}", "wing"), (f"/api/v1/wings/{big}/bases", "wing"),
                           (f"/api/v1/wings/{big}/roms", "wing"), (f"/api/v1/evaluations/{big}", "evaluation_id"),
                           (f"/api/v1/evaluations/{big}/vg", "evaluation_id"),
                           (f"/api/v1/evaluations/{big}/plot.png", "evaluation_id"),
                           (f"/api/v1/bases/{big}/shapes.png", "basis_id"),
                           (f"/api/v1/bases/{big}/mac.svg", "basis_id"),
                           (f"/api/v1/roms/{big}/mean-flow", "rom_id")):
            problem(client.get(url), 404, field)
        problem(client.post(f"/api/v1/wings/{big}/flutter", json={"design": [0.3] * 7}), 404, "wing")
        problem(client.post(f"/api/v1/wings/{big}/flutter/batch", json={"designs": [[0.3] * 7]}), 404, "wing")
        problem(client.post(f"/api/v1/wings/{big}/basis", json={}), 404, "wing")
        problem(client.post(f"/api/v1/wings/{big}/roms", json={"mach": 0.8}), 404, "wing")
        if big > 2**31 - 1:
            problem(client.get("/api/v1/evaluations", params={"wing_id": big}), 422, "wing_id")
            problem(client.get(f"/api/v1/wings/{wid}/roms", params={"basis_id": big}), 422, "basis_id")
            problem(client.post(f"/api/v1/wings/{wid}/flutter", json={"design": [0.3] * 7, "basis_id": big}),
                    422, "basis_id")
            problem(client.post(f"/api/v1/wings/{wid}/flutter", json={"modes_id": big}), 422, "modes_id")
            problem(client.post(f"/api/v1/wings/{wid}/flutter/batch", json={"designs": [[0.3] * 7], "basis_id": big}),
                    422, "basis_id")
            problem(client.post(f"/api/v1/wings/{wid}/roms", json={"mach": 0.8, "basis_id": big}), 422, "basis_id")
            problem(client.put(f"/api/v1/wings/{wid}/active-basis", json={"basis_id": big}), 422, "basis_id")
    problem(client.get("/api/v1/wings/%C2%B2"), 404, "wing")  # a unicode digit is a name, not an id
    assert client.get(f"/api/v1/evaluations?wing_id={2**31 - 1}").json() == []
    assert _rows(client) == before


def test_nul_characters_are_422_naming_the_field(client):
    before = _rows(client)
    problem(client.get("/api/v1/wings/a%00b"), 422, "wing", "NUL")
    problem(client.get("/api/v1/wings/a%00b/roms"), 422, "wing", "NUL")
    problem(client.post("/api/v1/wings/a%00b/flutter", json={"design": [0.3] * 7}), 422, "wing", "NUL")
    problem(client.get("/api/v1/jobs/x%00y"), 422, "job_id", "NUL")
    problem(client.post("/api/v1/jobs/x%00y/cancel"), 422, "job_id", "NUL")
    problem(client.get("/api/v1/jobs", params={"kind": "basis\x00"}), 422, "kind", "NUL")
    problem(client.post("/api/v1/wings", json={"template": "goland", "name": "a\x00b"}), 422, "name", "NUL")
    problem(client.post("/api/v1/wings", json={"template": "gol\x00and"}), 422, "template", "NUL")
    from romams_core.wing import template

    d = template("cropped-delta").to_dict()
    d["name"] = "nul\x00wing"
    problem(client.post("/api/v1/wings", json={"definition": d}), 422, "definition.name", "NUL")
    d["name"] = "n" * 201  # longer than the name column
    problem(client.post("/api/v1/wings", json={"definition": d}), 422, "definition.name", "at most 200")
    assert _rows(client) == before
    wid = client.post("/api/v1/wings", json={"template": "cropped-delta"}).json()["id"]
    roms = f"/api/v1/wings/{wid}/roms"
    problem(client.post(roms, json={"mach": 0.8, "options": {"k\x00": 1}}), 422, "options", "NUL")
    problem(client.post(roms, json={"mach": 0.8, "options": {"note": ["ok", "b\x00d"]}}), 422, "options.note[1]", "NUL")
    up = client.post("/api/v1/modes", files={"file": ("a\x00b.json", b"{oops")})
    assert up.status_code == 422 and up.headers["content-type"].startswith("application/problem+json")
    assert _rows(client)[1] == 0  # no job


def test_types_are_strict_no_string_to_number_coercion(client):
    wid = client.post("/api/v1/wings", json={"template": "cropped-delta"}).json()["id"]
    before = _rows(client)
    basis, roms, flutter = (f"/api/v1/wings/{wid}/{p}" for p in ("basis", "roms", "flutter"))
    for body, field in (({"samples": "25"}, "samples"), ({"samples": 25.0}, "samples"), ({"samples": True}, "samples"),
                        ({"seed": "1"}, "seed"), ({"mac_threshold": "0.99"}, "mac_threshold")):
        problem(client.post(basis, json=body), 422, field)
    for body, field in (({"mach": "0.8"}, "mach"), ({"machs": ["0.8"]}, "machs[0]"), ({"mach": 0.8, "na": "8"}, "na"),
                        ({"mach": 0.8, "basis_id": "1"}, "basis_id")):
        problem(client.post(roms, json=body), 422, field)
    for body, field in (({"design": {"x1": "0.3"}}, "design.x1"), ({"design": ["0.3"] * 7}, "design[0]"),
                        ({"design": [0.3] * 7, "store": "true"}, "store"),
                        ({"design": [0.3] * 7, "altitude_ref_m": "100"}, "altitude_ref_m"),
                        ({"design": [0.3] * 7, "machs": ["0.8"]}, "machs[0]"), ({"modes_id": "1"}, "modes_id")):
        problem(client.post(flutter, json=body), 422, field)
    problem(client.post(f"{flutter}/batch", json={"designs": [[0.3] * 6 + ["1"]]}), 422, "designs[0][6]")
    problem(client.put(f"/api/v1/wings/{wid}/active-basis", json={"basis_id": "1"}), 422, "basis_id")
    problem(client.post("/api/v1/wings", json={"template": 7}), 422, "template")
    assert _rows(client) == before
    # an integer is a valid number where a float is expected (as in JSON): these pass validation and stop at 409
    problem(client.post(roms, json={"mach": 0}), 409, "basis_id")
    problem(client.post(flutter, json={"design": [0, 1, 1, 0, 1, 1, 1], "altitude_ref_m": 5000}), 409, "basis_id")


# ---- body, batch and upload limits --------------------------------------------------------------------------------
@pytest.fixture()
def small(tmp_path):
    settings = Settings(data_dir=tmp_path / "data", request_max_bytes=4096, upload_max_bytes=1_000_000,
                        upload_inflated_max_bytes=1_000_000, batch_max=3)
    with TestClient(create_app(settings, celery=SentTasks(), sweeper=False)) as c:
        yield c


def test_request_body_limit_is_413_before_the_body_is_read(small):
    big = json.dumps({"template": "goland", "name": "x" * 5000}).encode()
    r = small.post("/api/v1/wings", content=big, headers={"content-type": "application/json"})
    body = problem(r, 413, "body", "4096 bytes")
    assert body["instance"] == "/api/v1/wings"

    def chunks():  # no Content-Length: counted while it streams in
        yield b'{"template": "goland", "name": "'
        for _ in range(8):
            yield b"x" * 1000
        yield b'"}'

    problem(small.post("/api/v1/wings", content=chunks(), headers={"content-type": "application/json"}), 413, "body")
    problem(small.post("/api/v1/wings", content=b"{}", headers={"content-type": "application/json",
                                                                   "content-length": "-5"}), 400, "content-length")
    assert small.get("/api/v1/wings").json() == []
    assert small.post("/api/v1/wings", json={"template": "goland"}).status_code == 201  # under the limit


def test_a_body_without_a_valid_key_is_refused_unread(tmp_path):
    settings = Settings(data_dir=tmp_path / "data", api_keys=["k1"], request_max_bytes=4096)
    with TestClient(create_app(settings, celery=SentTasks(), sweeper=False)) as c:
        big = b"[" + b"1," * 100_000 + b"1]"  # larger than the limit and not even an object: the key comes first
        problem(c.post("/api/v1/wings/1/flutter/batch", content=big, headers={"content-type": "application/json"}),
                401, "authorization")
        problem(c.post("/api/v1/wings/1/flutter/batch", content=big,
                       headers={"content-type": "application/json", "authorization": "Bearer nope"}),
                403, "authorization")
        problem(c.post("/api/v1/wings/1/flutter/batch", content=big,
                       headers={"content-type": "application/json", "authorization": "Bearer k1"}), 413, "body")


def test_batch_size_limit_names_the_field(small):
    wid = small.post("/api/v1/wings", json={"template": "cropped-delta"}).json()["id"]
    problem(small.post(f"/api/v1/wings/{wid}/flutter/batch", json={"designs": [[0.3] * 7] * 4}), 413, "designs",
            "at most 3")
    assert small.get("/api/v1/jobs").json() == []


def _npz(**arrays) -> bytes:
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)
    return buf.getvalue()


def _modes_arrays() -> dict:
    x, y = np.meshgrid(np.linspace(0, 1, 5), np.linspace(0, 1, 5))
    nodes = np.column_stack([x.ravel(), y.ravel(), 0 * x.ravel()])
    return {"nodes": nodes, "shapes": (y.ravel() ** 2)[:, None], "frequencies_hz": np.array([10.0])}


def test_uploads_are_bounded_and_npz_sizes_checked_before_decompression(small):
    ok = small.post("/api/v1/modes", files={"file": ("m.npz", _npz(**_modes_arrays()))})
    assert ok.status_code == 201, ok.text
    problem(small.post("/api/v1/modes", files={"file": ("m.json", b" " * 1_500_000)}), 413, "file", "1000000 bytes")
    problem(small.post("/api/v1/modes", files={"bdf": ("m.bdf", b"x" * 1_500_000), "op2": ("m.op2", b"x")}), 413,
            "bdf")
    problem(small.post("/api/v1/modes", files={"file": ("m.json", b" " * 4_000_000)}), 413, "body")  # whole body

    # a bomb: 200 MB of zeros in a few hundred kB (the member's size is declared in the zip directory)
    bomb = io.BytesIO()
    with zipfile.ZipFile(bomb, "w", zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("nodes.npy", _npy(_modes_arrays()["nodes"]))
        zf.writestr("frequencies_hz.npy", _npy(np.array([10.0])))
        with zf.open("shapes.npy", "w", force_zip64=True) as f:
            f.write(_npy_header((25_000_000,)))
            zero = bytes(1 << 20)
            for _ in range(200):
                f.write(zero)
    assert len(bomb.getvalue()) < 1_000_000
    tracemalloc.start()
    try:
        r = small.post("/api/v1/modes", files={"file": ("bomb.npz", bomb.getvalue())})
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    problem(r, 422, "file.shapes", "bytes")
    assert peak < 20e6, peak  # rejected from the directory and the header, nothing inflated

    # a header that claims a huge array in a small member (numpy would allocate it before reading)
    liar = io.BytesIO()
    with zipfile.ZipFile(liar, "w", zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("nodes.npy", _npy(_modes_arrays()["nodes"]))
        zf.writestr("frequencies_hz.npy", _npy(np.array([10.0])))
        zf.writestr("shapes.npy", _npy_header((10**10, 4)) + bytes(64))
    problem(small.post("/api/v1/modes", files={"file": ("liar.npz", liar.getvalue())}), 422, "file.shapes")

    # object arrays need pickle: never loaded
    pickled = io.BytesIO()
    np.savez(pickled, nodes=_modes_arrays()["nodes"], shapes=np.array([1, "x"], dtype=object),
             frequencies_hz=[10.0])
    problem(small.post("/api/v1/modes", files={"file": ("obj.npz", pickled.getvalue())}), 422, "file.shapes",
            "pickle")
    assert len(small.get("/api/v1/jobs").json()) == 0


def _npy(a: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.save(buf, a, allow_pickle=False)
    return buf.getvalue()


def _npy_header(shape: tuple) -> bytes:
    """The .npy header of a float64 array of ``shape`` (version 1.0)."""
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": "<f8", "fortran_order": False, "shape": shape})
    return buf.getvalue()


# ---- security headers ----------------------------------------------------------------------------------------------
def test_security_headers_on_dashboard_api_static_and_errors(small):
    for url in ("/dashboard", "/api/v1/health", "/api/v1/wings", "/api/v1/wings/999", "/static/dashboard.js",
                "/openapi.json", "/api/v1/nowhere"):
        r = small.get(url)
        assert r.headers["x-frame-options"] == "DENY", url
        assert r.headers["x-content-type-options"] == "nosniff", url
        assert r.headers["referrer-policy"] == "no-referrer", url
        csp = r.headers["content-security-policy"]
        assert "frame-ancestors 'none'" in csp and "default-src 'none'" in csp, (url, csp)
        assert "script-src 'self';" in csp and "unsafe-inline" not in csp, (url, csp)
    r = small.post("/api/v1/wings", content=b"x" * 5000, headers={"content-type": "application/json"})
    problem(r, 413)
    assert r.headers["x-frame-options"] == "DENY" and "content-security-policy" in r.headers
    # the dashboard needs nothing the policy forbids: no inline script or style, same-origin fetches and images
    page = small.get("/dashboard").text
    assert "style=" not in page and "<script>" not in page and 'src="http' not in page
    assert "<script src=\"/static/dashboard.js\">" in page
    js = small.get("/static/dashboard.js").text
    assert "style=" not in js and "el.style.width" in js
    docs = small.get("/docs")  # Swagger UI from this server only (no CDN, no inline script), still no framing
    assert "script-src 'self';" in docs.headers["content-security-policy"]
    assert "https:" not in docs.headers["content-security-policy"]
    assert "frame-ancestors 'none'" in docs.headers["content-security-policy"]


# ---- database faults: 503 + Retry-After --------------------------------------------------------------------------
def _assert_503(r) -> None:
    body = problem(r, 503, contains="database")
    assert int(r.headers["retry-after"]) >= 1, r.headers
    assert "unavailable" in body["detail"]


def _outage_requests(c, wid: int | None = None) -> None:
    """A GET and a POST of several kinds while the database is down: each a 503 problem with Retry-After."""
    for url in ("/api/v1/wings", "/api/v1/jobs", "/api/v1/evaluations", "/api/v1/health", "/dashboard",
                "/api/v1/wings/cropped-delta"):
        _assert_503(c.get(url))
    _assert_503(c.post("/api/v1/wings", json={"template": "goland", "name": "during-outage"}))
    _assert_503(c.post("/api/v1/jobs/abc/cancel"))
    if wid is not None:
        _assert_503(c.post(f"/api/v1/wings/{wid}/basis", json={"samples": 4}))
        _assert_503(c.post(f"/api/v1/wings/{wid}/flutter", json={"design": [0.3] * 7}))


def test_unreachable_database_gives_503_with_retry_after(tmp_path):
    """An app whose database is a PostgreSQL URL on a port where nothing listens (connection refused)."""
    from romams.persistence import Store
    from romams.persistence.engine import get_engine

    settings = Settings(data_dir=tmp_path / "data", retry_after_s=7, db_connect_timeout_s=2)
    app = create_app(settings, celery=SentTasks(), sweeper=False)
    with TestClient(app) as c:
        assert c.post("/api/v1/wings", json={"template": "goland"}).status_code == 201
        down = Store(get_engine("postgresql+psycopg://postgres@127.0.0.1:1/none", connect_timeout_s=2), settings)
        app.state.service.store = down
        _outage_requests(c)
        assert c.get("/api/v1/wings").headers["retry-after"] == "7"


class TcpProxy:
    """127.0.0.1:<port> forwarded to ``target``: ``stop()`` closes the listener and every open connection (a
    database outage as the API sees it, without touching the server), ``start()`` listens again on the same port."""

    def __init__(self, target: tuple[str, int]) -> None:
        self.target, self.port = target, 0
        self._socks: set[socket.socket] = set()
        self._lock = threading.Lock()
        self._stop = threading.Event()

    def start(self) -> TcpProxy:
        srv = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        srv.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        srv.bind(("127.0.0.1", self.port))
        srv.listen(64)
        srv.settimeout(0.1)
        self.port = srv.getsockname()[1]
        self._srv, self._stop = srv, threading.Event()
        threading.Thread(target=self._accept, args=(srv, self._stop), daemon=True).start()
        return self

    def _accept(self, srv: socket.socket, stop: threading.Event) -> None:
        while not stop.is_set():
            try:
                client, _ = srv.accept()
            except TimeoutError:
                continue
            except OSError:
                return
            try:
                upstream = socket.create_connection(self.target, timeout=5)
            except OSError:
                client.close()
                continue
            client.settimeout(None)
            upstream.settimeout(None)
            with self._lock:
                self._socks.update((client, upstream))
            for a, b in ((client, upstream), (upstream, client)):
                threading.Thread(target=self._pump, args=(a, b), daemon=True).start()

    def _pump(self, a: socket.socket, b: socket.socket) -> None:
        try:
            while data := a.recv(65536):
                b.sendall(data)
        except OSError:
            pass
        finally:
            for s in (a, b):
                try:
                    s.shutdown(socket.SHUT_RDWR)
                except OSError:
                    pass

    def stop(self) -> None:
        self._stop.set()
        self._srv.close()
        with self._lock:
            socks, self._socks = list(self._socks), set()
        for s in socks:
            try:
                s.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass
            s.close()


@pytest.mark.services
def test_postgresql_outage_gives_503_then_recovers_without_loss(pg_url, tmp_path):
    """The API's PostgreSQL connections go through a proxy that is stopped (refused, pooled connections cut)
    and started again: 503 problems with Retry-After during the outage, never a 500; afterwards the pre-pinged pool
    reconnects and every row written before is there."""
    parts = urlsplit(pg_url)
    proxy = TcpProxy((parts.hostname or "127.0.0.1", parts.port or 5432)).start()
    url = urlunsplit(parts._replace(netloc=f"{parts.username}@127.0.0.1:{proxy.port}"))
    settings = Settings(data_dir=tmp_path / "data", database_url=url, db_connect_timeout_s=2)
    open_store(settings, migrate=True)
    try:
        with TestClient(create_app(settings, celery=SentTasks(), sweeper=False)) as c:
            wid = c.post("/api/v1/wings", json={"template": "cropped-delta"}).json()["id"]
            assert c.get("/api/v1/wings").status_code == 200  # the pool holds live connections
            proxy.stop()
            _outage_requests(c, wid)
            proxy.start()
            wings = c.get("/api/v1/wings")
            assert wings.status_code == 200 and [w["name"] for w in wings.json()] == ["cropped-delta"]
            assert c.post("/api/v1/wings", json={"template": "goland"}).status_code == 201
            assert c.get("/api/v1/health").json()["database"] == "postgresql"
    finally:
        proxy.stop()
