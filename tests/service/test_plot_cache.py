"""Plot endpoints: PNGs cached by the content hash of the data drawn, ETag / If-None-Match revalidation (304),
the speed-axis choice (422 on others). Embedded SQLite service without a worker; evaluations stored directly."""

from __future__ import annotations

import pytest
from fastapi.testclient import TestClient

from api.app import create_app
from benchmarks.dashboard_plots import example_evaluation, example_summary
from romams.settings import Settings


@pytest.fixture(scope="module")
def svc(tmp_path_factory):
    app = create_app(Settings(data_dir=tmp_path_factory.mktemp("plots")), sweeper=False)
    with TestClient(app) as client:
        wid = client.post("/api/v1/wings", json={"template": "cropped-delta", "name": "cd-plots"}).json()["id"]
        store = app.state.service.store
        base = example_evaluation(1.0)
        res = example_evaluation(1.1, base.envelope)
        ids = [store.evaluations.save(wid, res, summary=example_summary(wid, res), request={"design": [i]})
               for i in range(2)]  # the same data stored twice
        yield client, app, ids


def test_cached_bytes_etag_and_304(svc):
    client, app, (eid, twin) = svc
    url = f"/api/v1/evaluations/{eid}/plot.png"
    first = client.get(url, params={"kind": "vg", "mach": 0.87})
    assert first.status_code == 200 and first.content[:4] == b"\x89PNG"
    etag = first.headers["etag"]
    assert first.headers["cache-control"] == "no-cache" and etag.startswith('"')
    hits = app.state.plot_cache.hits
    again = client.get(url, params={"kind": "vg", "mach": 0.87})
    assert again.content == first.content and again.headers["etag"] == etag
    assert app.state.plot_cache.hits == hits + 1  # served from the cache, not rendered again
    # keyed by content: another row with the same data has the same ETag and bytes
    other = client.get(f"/api/v1/evaluations/{twin}/plot.png", params={"kind": "vg", "mach": 0.87})
    assert other.headers["etag"] == etag and other.content == first.content
    not_mod = client.get(url, params={"kind": "vg", "mach": 0.87}, headers={"If-None-Match": f'W/"x", {etag}'})
    assert not_mod.status_code == 304 and not_mod.content == b"" and not_mod.headers["etag"] == etag
    stale = client.get(url, params={"kind": "vg", "mach": 0.87}, headers={"If-None-Match": '"0000"'})
    assert stale.status_code == 200 and stale.content == first.content


def test_axis_choice_and_envelope(svc):
    client, _, (eid, _) = svc
    url = f"/api/v1/evaluations/{eid}/plot.png"
    tags = set()
    for axis in ("tas", "eas", "q"):
        r = client.get(url, params={"axis": axis})
        assert r.status_code == 200 and r.content[:4] == b"\x89PNG"
        tags.add(r.headers["etag"])
    assert len(tags) == 3  # the option is part of the key
    bad = client.get(url, params={"axis": "mach"})
    assert bad.status_code == 422 and bad.headers["content-type"].startswith("application/problem+json")
    assert bad.json()["field"] == "axis"
    env = client.get(url, params={"kind": "envelope"})
    assert env.status_code == 200 and env.content[:4] == b"\x89PNG" and env.headers["etag"] not in tags
    svg = client.get(f"/api/v1/evaluations/{eid}/plot.svg", params={"kind": "envelope"})
    assert svg.status_code == 200 and svg.headers["content-type"].startswith("image/svg+xml")
    assert client.get(f"/api/v1/evaluations/{eid}/plot.svg", params={"kind": "envelope"}).content == svg.content
