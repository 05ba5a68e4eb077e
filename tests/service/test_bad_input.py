"""Bad input for every endpoint: 4xx problem+json naming the field and the reason, never a 500, nothing stored.

No worker runs here: validation happens in the API before anything is queued. (Flutter inputs that need
trained ROMs are checked in test_api_sqlite.py.)
"""

from __future__ import annotations

import json

import pytest
from fastapi.testclient import TestClient

from api.app import create_app
from romams.settings import Settings


@pytest.fixture()
def client(tmp_path):
    app = create_app(Settings(data_dir=tmp_path, max_samples=50), sweeper=False)
    with TestClient(app) as c:
        yield c


def problem(r, status: int, field: str | None = None, contains: str = "") -> dict:
    """Assert a problem+json response with this status (and field / text)."""
    assert r.status_code == status, (r.status_code, r.text)
    assert r.headers["content-type"].startswith("application/problem+json"), r.headers
    body = r.json()
    assert body["status"] == status and body["title"] and body["detail"]
    if field is not None:
        assert body.get("field") == field, body
    assert contains.lower() in body["detail"].lower(), body
    return body


def _counts(c) -> tuple:
    wings = c.get("/api/v1/wings").json()
    jobs = c.get("/api/v1/jobs", params={"limit": 1000, "include_children": True}).json()
    return len(wings), len(jobs), sum(len(c.get(f"/api/v1/wings/{w['id']}/bases").json()) for w in wings)


def test_wing_creation_errors(client):
    problem(client.post("/api/v1/wings", json={}), 422, "body", "exactly one")
    problem(client.post("/api/v1/wings", json={"template": "nope"}), 422, "template", "unknown template")
    problem(client.post("/api/v1/wings", json={"template": "goland", "definition": {}}), 422, "body", "exactly one")
    problem(client.post("/api/v1/wings", json={"definition": {"name": "x"}}), 422, "definition.planform", "missing")
    problem(client.post("/api/v1/wings", json={"template": "goland", "name": "n" * 300}), 422, "name")
    problem(client.post("/api/v1/wings", json={"template": "goland", "colour": "red"}), 422, "colour", "extra")
    problem(client.post("/api/v1/wings", content=b"{not json", headers={"content-type": "application/json"}), 422)
    assert client.post("/api/v1/wings", json={"template": "goland"}).status_code == 201
    problem(client.post("/api/v1/wings", json={"template": "goland"}), 409, "name", "already exists")
    problem(client.get("/api/v1/wings/999"), 404, "wing")
    problem(client.get("/api/v1/wings/no-such-wing"), 404, "wing")
    assert [w["name"] for w in client.get("/api/v1/wings").json()] == ["goland"]


def test_full_definition_round_trip_and_errors(client):
    from romams_core.wing import template

    d = template("cropped-delta").to_dict()
    d["name"] = "custom"
    r = client.post("/api/v1/wings", json={"definition": d})
    assert r.status_code == 201, r.text
    got = client.get(f"/api/v1/wings/{r.json()['id']}").json()
    assert got["name"] == "custom" and len(got["design_variables"]) == 7
    bad = json.loads(json.dumps(d))
    bad["name"] = "custom-2"
    bad["planform"]["semispan"] = -1.0
    body = problem(client.post("/api/v1/wings", json={"definition": bad}), 422)
    assert "semispan" in body["detail"]


def test_basis_and_training_request_errors(client):
    wid = client.post("/api/v1/wings", json={"template": "cropped-delta"}).json()["id"]
    before = _counts(client)
    url = f"/api/v1/wings/{wid}/basis"
    problem(client.post(url, json={"samples": 1}), 422, "samples")
    problem(client.post(url, json={"samples": 51}), 422, "samples", "<= 50")
    problem(client.post(url, json={"modes": 0}), 422, "modes")
    problem(client.post(url, json={"modes": 21}), 422, "modes", "<= 20")
    problem(client.post(url, json={"mac_threshold": 1.5}), 422, "mac_threshold")
    problem(client.post(url, json={"samples": "many"}), 422, "samples")
    problem(client.post(url, json={"seed": -1}), 422, "seed")
    problem(client.post("/api/v1/wings/999/basis", json={}), 404, "wing")
    roms = f"/api/v1/wings/{wid}/roms"
    problem(client.post(roms, json={"mach": 0.8}), 409, "basis_id", "no basis")
    problem(client.post(roms, json={"mach": 0.8, "machs": [0.9]}), 422, "body", "exactly one")
    problem(client.post(roms, json={}), 422, "body", "exactly one")
    problem(client.post(roms, json={"mach": -0.1}), 422, "mach")
    problem(client.post(roms, content=b'{"mach": NaN}', headers={"content-type": "application/json"}), 422, "mach")
    problem(client.post(roms, json={"machs": [0.8, 3.0]}), 422, "body", "outside")
    problem(client.post(roms, json={"mach": 0.8, "solver": "cfd"}), 422, "solver")
    problem(client.post(roms, json={"mach": 0.8, "na": 0}), 422, "na")
    assert _counts(client) == before  # nothing stored or queued by any of them


def test_training_errors_once_a_basis_exists(client, tmp_path):
    """With a (real) stored basis: supersonic UVLM, unknown options, another wing's basis."""
    import numpy as np

    from romams.persistence import open_store
    from romams_core.basis import build_basis

    store = client.app.state.service.store
    wid = client.post("/api/v1/wings", json={"template": "cropped-delta"}).json()["id"]
    other = client.post("/api/v1/wings", json={"template": "goland"}).json()["id"]
    snaps = np.linalg.qr(np.random.default_rng(0).standard_normal((187, 6)))[0]
    bid = store.bases.save(wid, build_basis(snaps, n_modes=3), {"samples": 2, "modes": 3})
    assert open_store(client.app.state.service.settings).bases.latest(wid)[0] == bid
    # stored directly, not by a basis job: not active until activated
    problem(client.post(f"/api/v1/wings/{wid}/roms", json={"mach": 0.8}), 409, "basis_id", "no basis")
    assert client.put(f"/api/v1/wings/{wid}/active-basis", json={"basis_id": bid}).status_code == 200
    before = _counts(client)
    roms = f"/api/v1/wings/{wid}/roms"
    problem(client.post(roms, json={"mach": 1.2}), 422, "mach", "subsonic")
    problem(client.post(roms, json={"mach": 0.8, "options": {"wrong": 1}}), 422, "options.wrong", "not a training")
    problem(client.post(roms, json={"mach": 0.8, "options": {"n_steps": [1, 2]}}), 422, "options.n_steps")
    problem(client.post(roms, json={"machs": [0.8, 0.8]}), 422, "machs", "duplicates")
    problem(client.post(f"/api/v1/wings/{other}/roms", json={"mach": 0.8, "basis_id": bid}), 404, "basis_id")
    problem(client.post(f"/api/v1/wings/{wid}/flutter", json={"design": [0.3] * 7}), 409, "machs", "no ROM")
    # the transonic solver: subsonic free stream only, thin sections, a grid fine enough for the basis
    tsd = {"solver": "tsd"}
    problem(client.post(roms, json={"mach": 1.0, **tsd}), 422, "mach", "subsonic")
    problem(client.post(roms, json={"machs": [0.9, 1.05], **tsd}), 422, "machs", "subsonic")
    problem(client.post(roms, json={"mach": 0.0, **tsd}), 422, "mach", "Mach >= 0.4")
    problem(client.post(roms, json={"machs": [0.9, 0.3], **tsd}), 422, "machs", "use the dlm")
    problem(client.post(roms, json={"mach": 0.9, "options": {"thickness_to_chord": 0.2,
                                                              "thickness_form": "naca4"}, **tsd}),
            422, "options.thickness_to_chord", "thin-wing")
    problem(client.post(roms, json={"mach": 0.9, "options": {"grid_scale": 0.25}, **tsd}), 422,
            "options.grid_scale", "too coarse for")
    problem(client.post(roms, json={"mach": 0.9, "options": {"tsd_dt": 0.5}, **tsd}), 422, "options.tsd_dt")
    problem(client.post(roms, json={"mach": 0.9, "options": {"coefficients": "x"}, **tsd}), 422,
            "options.coefficients")
    problem(client.post(roms, json={"mach": 0.9, "options": {"low_k_corner": 2.0}, **tsd}), 422,
            "options.low_k_corner", "<= 1.5")
    problem(client.post(roms, json={"mach": 0.9, "options": {"low_k_corner": 0.2, "k_max": 0.1}, **tsd}), 422,
            "options.low_k_corner", "<= 0.1")
    for bad, why in (([0.05, 2.0], "k_max = 1.5"), ("fast", "list of reduced frequencies"), ([0.1] * 5, "1 to 4"),
                     ([[0.05], [0.1]], "finite numbers"), ([0.1, 0.1], "distinct")):
        problem(client.post(roms, json={"mach": 0.9, "options": {"anchor_k": bad}, **tsd}), 422,
                "options.anchor_k", why)
    for bad in (5.0, 1e6, "long"):  # the step records' hold (t*)
        problem(client.post(roms, json={"mach": 0.9, "options": {"anchor_hold": bad}, **tsd}), 422,
                "options.anchor_hold")
    for bad in (0.5, 8.0, "fine"):  # the grid refinement of a supercritical mean flow: none or 1-4
        problem(client.post(roms, json={"mach": 0.9, "options": {"supercritical_refine": bad}, **tsd}), 422,
                "options.supercritical_refine")
    problem(client.post(roms, json={"mach": 0.9, "options": {"validation_band": 1.0}, **tsd}), 422,
            "options.validation_band", ">= 1.5")  # below the excitation band's k_max
    assert _counts(client) == before


def test_job_endpoint_errors(client):
    problem(client.get("/api/v1/jobs/not-a-job"), 404, "job_id")
    problem(client.post("/api/v1/jobs/not-a-job/cancel"), 404, "job_id")
    problem(client.get("/api/v1/jobs", params={"status": "bogus"}), 422, "status")
    problem(client.get("/api/v1/jobs", params={"limit": 0}), 422, "limit")
    problem(client.get("/api/v1/jobs/" + "x" * 200), 404, "job_id")


def test_evaluation_and_plot_errors(client):
    problem(client.get("/api/v1/evaluations/12345"), 404, "evaluation_id")
    problem(client.get("/api/v1/evaluations/12345/vg"), 404, "evaluation_id")
    problem(client.get("/api/v1/evaluations/12345/plot.png"), 404, "evaluation_id")
    problem(client.get("/api/v1/evaluations/1/plot.gif"), 422, "fmt")
    problem(client.get("/api/v1/evaluations/1/plot.png", params={"kind": "polar"}), 422, "kind")
    problem(client.get("/api/v1/evaluations/abc"), 422, "evaluation_id")
    problem(client.get("/api/v1/bases/777/shapes.png"), 404, "basis_id")
    problem(client.post("/api/v1/wings/999/flutter", json={"design": [0.3] * 7}), 404, "wing")
    problem(client.post("/api/v1/wings/999/flutter/batch", json={"designs": [[0.3] * 7]}), 404, "wing")


def test_modes_upload_errors(client):
    problem(client.post("/api/v1/modes"), 422, "file")
    problem(client.post("/api/v1/modes", files={"bdf": ("m.bdf", b"CEND\n")}), 422, "op2", "both")
    problem(client.post("/api/v1/modes", files={"file": ("m.txt", b"1 2 3")}), 422, "file", ".json or .npz")
    problem(client.post("/api/v1/modes", files={"file": ("m.json", b"{oops")}), 422, "file", "not valid json")
    problem(client.post("/api/v1/modes", files={"file": ("m.json", b'{"nodes": [[0, 0, 0]]}')}), 422, "file.shapes")
    problem(client.post("/api/v1/modes", files={"file": ("m.npz", b"PK-not-a-zip")}), 422, "file")
    r = client.post("/api/v1/modes", files={"bdf": ("m.bdf", b"garbage"), "op2": ("m.op2", b"garbage")})
    assert r.status_code in (422, 501) and r.headers["content-type"].startswith("application/problem+json")


def test_json_modes_upload_is_stored(client):
    import numpy as np

    x, y = np.meshgrid(np.linspace(0, 1, 5), np.linspace(0, 1, 5))
    body = {"nodes": np.column_stack([x.ravel(), y.ravel(), 0 * x.ravel()]).tolist(),
            "shapes": [(y.ravel() ** 2).tolist()], "frequencies_hz": [10.0]}
    r = client.post("/api/v1/modes", files={"file": ("m.json", json.dumps(body).encode())})
    assert r.status_code == 201, r.text
    assert r.json()["n_nodes"] == 25 and r.json()["n_modes"] == 1 and r.json()["frequencies_hz"] == [10.0]


def test_api_keys_guard_mutating_endpoints(tmp_path):
    app = create_app(Settings(data_dir=tmp_path, api_keys=["k1", "k2"]), sweeper=False)
    with TestClient(app) as c:
        body = problem(c.post("/api/v1/wings", json={"template": "goland"}), 401, "authorization")
        assert body["detail"].startswith("authorization")
        r = c.post("/api/v1/wings", json={"template": "goland"})
        assert r.headers.get("www-authenticate") == "Bearer"
        problem(c.post("/api/v1/wings", json={"template": "goland"}, headers={"Authorization": "Bearer nope"}),
                403, "authorization")
        problem(c.post("/api/v1/wings", json={"template": "goland"}, headers={"Authorization": "Basic k1"}),
                401, "authorization")
        ok = c.post("/api/v1/wings", json={"template": "goland"}, headers={"Authorization": "Bearer k2"})
        assert ok.status_code == 201
        problem(c.get("/api/v1/wings"), 401, "authorization")  # with keys configured, reads need one too
        assert c.get("/api/v1/wings", headers={"Authorization": "Bearer k1"}).status_code == 200
        assert c.get("/api/v1/health").status_code == 200  # the health check stays open
        problem(c.post("/api/v1/jobs/x/cancel"), 401)
        problem(c.post("/api/v1/modes"), 401)


def test_openapi_documents_the_contract(client):
    spec = client.get("/openapi.json").json()
    paths = spec["paths"]
    for p in ("/api/v1/wings", "/api/v1/wings/{wing}", "/api/v1/wings/{wing}/basis", "/api/v1/wings/{wing}/bases",
              "/api/v1/wings/{wing}/roms", "/api/v1/jobs", "/api/v1/jobs/{job_id}", "/api/v1/jobs/{job_id}/cancel",
              "/api/v1/wings/{wing}/flutter", "/api/v1/wings/{wing}/flutter/batch", "/api/v1/modes",
              "/api/v1/evaluations/{evaluation_id}/vg", "/api/v1/evaluations/{evaluation_id}/plot.{fmt}"):
        assert p in paths, p
    for p in ("/api/v1/evaluations/{evaluation_id}/plot.{fmt}", "/api/v1/bases/{basis_id}/shapes.{fmt}"):
        assert set(paths[p]["get"]["responses"]["200"]["content"]) == {"image/png", "image/svg+xml"}, p
    post = paths["/api/v1/wings/{wing}/flutter"]["post"]["responses"]
    for status in ("400", "401", "403", "404", "409", "413", "422", "429", "503"):
        assert set(post[status]["content"]) == {"application/problem+json"}, status
    assert "Retry-After" in post["503"]["headers"] and "WWW-Authenticate" in post["401"]["headers"]
    assert "Retry-After" in post["429"]["headers"]
    assert spec["components"]["securitySchemes"]["bearer"]["scheme"] == "bearer"
    assert paths["/api/v1/wings"]["post"]["security"] == [{"bearer": []}]
    assert paths["/api/v1/wings"]["get"]["security"] == [{"bearer": []}]  # reads need a (read) key too
    assert "security" not in paths["/api/v1/health"]["get"]  # the health check is open
    assert {"title", "status", "detail"} <= set(spec["components"]["schemas"]["Problem"]["required"])
    r = client.delete("/api/v1/wings")  # 405 names every method of the path, not those of its first route
    assert r.status_code == 405 and r.headers["allow"] == "GET, POST"
    assert r.headers["content-type"] == "application/problem+json"
    assert client.get("/api/v1/health").json()["status"] == "ok"


def test_unreachable_broker_gives_503_and_a_failed_job(tmp_path):
    app = create_app(Settings(data_dir=tmp_path, broker_url="redis://127.0.0.1:1/0"), sweeper=False)
    with TestClient(app) as c:
        wid = c.post("/api/v1/wings", json={"template": "cropped-delta"}).json()["id"]
        r = c.post(f"/api/v1/wings/{wid}/basis", json={"samples": 4})
        problem(r, 503, contains="broker")
        jobs = c.get("/api/v1/jobs").json()
        assert len(jobs) == 1 and jobs[0]["status"] == "failed" and "could not enqueue" in jobs[0]["error"]


def test_a_query_parameter_given_twice_is_422_naming_it(client):
    wid = client.post("/api/v1/wings", json={"template": "cropped-delta"}).json()["id"]
    for path, name in ((f"/api/v1/wings/{wid}/roms?basis_id=1&basis_id=2", "basis_id"),
                       ("/api/v1/jobs?limit=5&kind=basis&limit=6", "limit"),
                       ("/api/v1/evaluations?wing_id=1&wing_id=1", "wing_id")):
        problem(client.get(path), 422, name, contains="given more than once")
    assert client.get(f"/api/v1/wings/{wid}/roms?basis_id=1").status_code == 200
    assert client.get("/api/v1/health?x=1&x=2").status_code == 200  # not a parameter of the route: ignored
