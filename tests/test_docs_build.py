"""The user docs build with MkDocs in strict mode (no warning: broken links, missing anchors, pages off the nav)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_mkdocs_builds_strict_with_the_generated_api_reference(tmp_path):
    """`mkdocs build --strict` succeeds and the API page lists every operation of the OpenAPI document."""
    site = tmp_path / "site"
    proc = subprocess.Popen([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(site)],
                            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    from api.openapi_doc import openapi_schema

    spec = openapi_schema()  # the reference, built while the site builds
    log, _ = proc.communicate(timeout=120)
    assert proc.returncode == 0, log
    assert "WARNING" not in log, log
    for page in ("index.html", "tutorial/index.html", "about/index.html", "howto/deploy/index.html"):
        assert (site / page).is_file(), page

    html = (site / "reference" / "api" / "index.html").read_text(encoding="utf-8")
    ops = [(m.upper(), p) for p, item in spec["paths"].items() for m in item if m in ("get", "post", "put", "delete")]
    assert len(ops) >= 20
    missing = [f"{m} {p}" for m, p in ops if f"{m} {p}" not in html]
    assert not missing, missing
    for model in spec["components"]["schemas"]:
        assert re.search(rf"<h3[^>]*>{re.escape(model)}", html), model


def test_api_reference_renders_parameters_body_responses_and_models():
    """The generated page states each operation's parameters, body model, response codes and model fields."""
    from api.openapi_doc import render

    spec = {
        "info": {"title": "t", "version": "1", "description": "d"},
        "paths": {"/api/v1/things/{thing}": {"post": {
            "tags": ["things"], "summary": "Make Thing", "description": "Make a thing.", "security": [{"bearer": []}],
            "parameters": [{"name": "thing", "in": "path", "required": True, "schema": {"type": "string"}},
                           {"name": "n", "in": "query", "schema": {"anyOf": [{"type": "integer"}, {"type": "null"}]},
                            "description": "how | many"}],
            "requestBody": {"required": True, "content": {"application/json": {
                "schema": {"$ref": "#/components/schemas/ThingIn"}}}},
            "responses": {"201": {"description": "made", "content": {"application/json": {
                "schema": {"type": "array", "items": {"$ref": "#/components/schemas/ThingIn"}}}}},
                "422": {"description": "bad", "content": {"application/problem+json": {
                    "schema": {"$ref": "#/components/schemas/Problem"}}}}}}}},
        "components": {"schemas": {"ThingIn": {"description": "A thing.", "required": ["size"], "properties": {
            "size": {"type": "number", "description": "size (m)"}}}}},
    }
    page = render(spec)
    assert "### `POST /api/v1/things/{thing}` {#post-api-v1-things-thing}" in page
    assert "**Make Thing** (API key when keys are set). Make a thing." in page
    assert "| `thing` | path | yes | string |  |" in page
    assert "| `n` | query | no | integer or null | how \\| many |" in page
    assert "**Request body** (required): `application/json`: ThingIn" in page
    assert "| 201 | `application/json` array of ThingIn | made |" in page
    assert "| 422 | `application/problem+json` Problem | bad |" in page
    assert "| `size` | number | yes | size (m) |" in page
