"""The interactive API docs work offline: /docs (Swagger UI) and /redoc load every asset from the service itself,
checked in a real headless Chromium with every request to another host aborted; and the OpenAPI document gives
every JSON route a typed response with an example and the problem+json error schema."""

from __future__ import annotations

import re
from urllib.parse import urlsplit

import pytest
from fastapi.testclient import TestClient

from api.app import create_app
from api.openapi import untyped_responses
from romams.settings import Settings

from .browser import chromium_page
from .conftest import SentTasks


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    """The app on a fresh SQLite store (no broker needed: nothing is queued)."""
    app = create_app(Settings(data_dir=tmp_path_factory.mktemp("docs")), celery=SentTasks(), sweeper=False)
    with TestClient(app) as c:
        yield c


@pytest.mark.parametrize("path", ["/docs", "/redoc"])
def test_docs_pages_reference_local_assets_only(client, path):
    r = client.get(path)
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/html")
    assert not re.findall(r"https?://", r.text), "an absolute URL: an asset from outside the server"
    assets = re.findall(r'(?:src|href)="([^"]+)"', r.text)
    assert assets, r.text
    for url in assets:  # every script, stylesheet and icon is served here
        assert url.startswith("/"), url
        got = client.get(url)
        assert got.status_code == 200 and len(got.content) > 100, url
    csp = r.headers["content-security-policy"]
    assert "script-src 'self';" in csp and "https:" not in csp and "frame-ancestors 'none'" in csp, csp


def test_openapi_types_every_json_response_with_an_example(client):
    spec = client.get("/openapi.json").json()
    assert untyped_responses(spec) == []
    schemas = spec["components"]["schemas"]
    assert "HTTPValidationError" not in schemas and "ValidationError" not in schemas
    problem = schemas["Problem"]
    assert {"type", "title", "status", "detail", "instance", "field", "errors"} <= set(problem["properties"])
    paths = spec["paths"]
    for status in ("404", "409", "413", "422", "429", "503"):
        content = paths["/api/v1/wings/{wing}/flutter/batch"]["post"]["responses"][status]["content"]
        assert set(content) == {"application/problem+json"}, status
        assert content["application/problem+json"]["example"]["status"] == int(status)
    ok = paths["/api/v1/jobs/{job_id}"]["get"]["responses"]["200"]["content"]["application/json"]["schema"]
    assert schemas[ok["$ref"].rsplit("/", 1)[1]]["examples"][0]["status"] == "running"
    for path in ("/api/v1/bases/{basis_id}/mac.{fmt}", "/api/v1/roms/{rom_id}/mean-flow.{fmt}"):
        assert set(paths[path]["get"]["responses"]["200"]["content"]) == {"image/png", "image/svg+xml"}, path


@pytest.mark.browser
def test_docs_render_with_the_network_blocked(server):
    base, _ = server
    local = urlsplit(base).netloc
    blocked: list[str] = []

    def only_local(route) -> None:
        if urlsplit(route.request.url).netloc == local:
            route.continue_()
        else:
            blocked.append(route.request.url)
            route.abort()

    with chromium_page(viewport={"width": 1280, "height": 900}) as (browser, page, errors):
        page.route("**/*", only_local)
        page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
        page.goto(f"{base}/docs")
        page.wait_for_selector(".opblock", timeout=20_000)
        assert page.locator(".opblock").count() > 20
        assert page.locator('.opblock-summary-path[data-path="/api/v1/health"]').count() == 1
        page.goto(f"{base}/redoc")
        page.wait_for_selector("[id$='operation/health_api_v1_health_get']", timeout=20_000)
        assert "/api/v1/health" in page.text_content(".api-content")
    # the one external URL in the bundled ReDoc: its attribution logo, refused by the page's CSP (the <img> removes
    # itself on error); no request leaves the browser for it
    errors = [e for e in errors if "cdn.redoc.ly/redoc/logo-mini.svg" not in e]
    assert blocked == [] and errors == [], (blocked, errors)


def test_every_documented_example_is_valid_for_its_model():
    import inspect

    from pydantic import BaseModel

    import api.responses
    import api.schemas
    from api.openapi import EXAMPLES, ProblemDetails, example_problem

    models = [m for mod in (api.responses, api.schemas) for _, m in inspect.getmembers(mod, inspect.isclass)
              if issubclass(m, BaseModel) and m.__module__ == mod.__name__]
    checked = 0
    for model in models:
        for ex in model.model_json_schema().get("examples", []):
            model.model_validate(ex, strict=False)  # raises (naming the model) when an example lies
            checked += 1
    assert checked >= 20, checked
    for status in EXAMPLES:
        assert ProblemDetails.model_validate(example_problem(status)).status == status
