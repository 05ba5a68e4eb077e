"""OpenAPI documentation of what the API sends besides its JSON results: problem+json errors, images.

Routes declare their error responses with :func:`problems` (shared sets: ``READ`` on every API router, ``WRITE`` on
mutating routes, ``WING`` and ``FOUND`` on routes that look a row up), and image routes with ``IMAGE``;
:func:`finish` adds the ``Problem`` schema and drops the empty ``application/json`` entry FastAPI adds next to a
declared content type.
"""

from __future__ import annotations

from typing import Any

from fastapi import Request
from fastapi.openapi.docs import get_redoc_html
from fastapi.responses import HTMLResponse
from fastapi.staticfiles import StaticFiles
from pydantic import BaseModel, ConfigDict, Field

from api.problems import PROBLEM_JSON

PROBLEM_REF = {"$ref": "#/components/schemas/Problem"}
RETRY_AFTER = {"Retry-After": {"description": "seconds to wait before retrying", "schema": {"type": "string"}}}
WWW_AUTHENTICATE = {"WWW-Authenticate": {"description": "Bearer", "schema": {"type": "string"}}}

#: why the API sends each error status (RFC 9457 problem+json bodies)
DESCRIPTIONS = {
    400: "malformed request: a body that cannot be parsed, or a Content-Length that is not a byte count",
    401: "no Bearer API key (keys are configured): WWW-Authenticate: Bearer",
    403: "the API key is not valid, or its scope is read and the endpoint mutates",
    404: "no such row: `field` names the id",
    409: "conflict with the stored state (a name taken, a job already final, a stored definition unreadable)",
    413: "request body, upload or batch larger than its limit",
    501: "the server lacks an optional part (pyNastran for Nastran files)",
    422: "invalid input: `field` names the first offending field, `errors` lists every one",
    429: "rate limit of the evaluation endpoints reached (per API key): retry after Retry-After seconds",
    503: "the database or the broker is unavailable: retry after Retry-After seconds",
}
HEADERS = {401: WWW_AUTHENTICATE, 429: RETRY_AFTER, 503: RETRY_AFTER}


class FieldError(BaseModel):
    """One validation error: the dotted path of the field and the reason."""

    field: str
    reason: str


class ProblemDetails(BaseModel):
    """RFC 9457 problem details (``field``: the offending input; more keys may follow, e.g. ``job_status``)."""

    model_config = ConfigDict(extra="allow", title="Problem")

    type: str = Field(default="about:blank", description="URI of the problem type (always about:blank: the status "
                      "says it all)")
    title: str = Field(description="the status's reason phrase")
    status: int = Field(description="the HTTP status code")
    detail: str = Field(description="what went wrong, starting with the offending field")
    field: str | None = Field(default=None, description="dotted path of the offending input (body, query, path or "
                              "form field; e.g. designs[3].t_skin_root)")
    instance: str | None = Field(default=None, description="the request path")
    errors: list[FieldError] | None = Field(default=None, description="every validation error (422)")


#: an example body of each error status (what the service sends; ``instance`` is the request path)
EXAMPLES: dict[int, dict[str, Any]] = {
    400: {"detail": "content-length: not a byte count", "field": "content-length"},
    401: {"detail": "authorization: a Bearer API key is required for this endpoint", "field": "authorization"},
    403: {"detail": "authorization: the API key is not valid", "field": "authorization"},
    404: {"detail": "wing: no wing 'nope'", "field": "wing", "instance": "/api/v1/wings/nope"},
    409: {"detail": "job_id: job 1b2c is already succeeded", "field": "job_id", "job_status": "succeeded"},
    413: {"detail": "designs: at most 2000 designs per batch, got 5000", "field": "designs"},
    422: {"detail": "samples: Input should be greater than or equal to 2", "field": "samples",
          "errors": [{"field": "samples", "reason": "Input should be greater than or equal to 2"}]},
    429: {"detail": "too many requests: retry after 1 s"},
    501: {"detail": "bdf: Nastran support (pyNastran) is not installed on this server", "field": "bdf"},
    503: {"detail": "database unavailable: connection refused"},
}


def example_problem(status: int) -> dict[str, Any]:
    """A problem+json body of ``status`` (RFC 9457 members first, then the service's own)."""
    from api.problems import TITLES

    return {"type": "about:blank", "title": TITLES.get(status, "Error"), "status": status, **EXAMPLES[status]}


def problems(*statuses: int) -> dict[int | str, dict[str, Any]]:
    """``responses=`` entries of the problem+json errors with these statuses (each with an example body)."""
    out: dict[int | str, dict[str, Any]] = {}
    for s in statuses:
        out[s] = {"description": DESCRIPTIONS[s],
                  "content": {PROBLEM_JSON: {"schema": PROBLEM_REF, "example": example_problem(s)}}}
        if s in HEADERS:
            out[s]["headers"] = HEADERS[s]
    return out


#: every API route but /health: the key (a read key at least, when keys are configured), invalid parameters,
#: database or broker down
READ = problems(401, 403, 422, 503)
#: mutating routes: the key (a write key, checked before the body is read), the body size, a body that cannot be
#: parsed
WRITE = problems(400, 401, 403, 413)
#: the evaluation routes: their rate limit
LIMITED = problems(429)
#: routes with a row id in their path
FOUND = problems(404)
#: routes of one wing (by id or name): not found, or its stored definition cannot be read
WING = problems(404, 409)
#: PNG/SVG plot routes (the extension in the path picks the format)
IMAGE: dict[int | str, dict[str, Any]] = {200: {"description": "the plot (PNG or SVG, by the path's extension)",
                                                "content": {"image/png": {"schema": {"type": "string",
                                                                                     "format": "binary"}},
                                                            "image/svg+xml": {"schema": {"type": "string"}}}}}


BEARER = {"type": "http", "scheme": "bearer",
          "description": "an API key of ROMAMS_API_KEYS (when keys are configured: a read key for GETs, a write key "
                         "for the mutating endpoints)"}


def finish(schema: dict[str, Any]) -> dict[str, Any]:
    """Add the Problem schema and the Bearer security scheme of the routes that answer 401; drop the empty
    ``application/json`` FastAPI puts next to another content type."""
    schema.setdefault("components", {}).setdefault("securitySchemes", {})["bearer"] = BEARER
    components = schema["components"].setdefault("schemas", {})
    problem = ProblemDetails.model_json_schema(ref_template="#/components/schemas/{model}")
    components.update(problem.pop("$defs", {}))
    components["Problem"] = problem
    from api.schemas import WingCreate  # POST /wings reads its JSON body itself (it also takes a deck upload)

    components.setdefault("WingCreate", WingCreate.model_json_schema(ref_template="#/components/schemas/{model}"))
    for path in schema.get("paths", {}).values():
        for operation in path.values():
            if "401" in operation.get("responses", {}):
                operation.setdefault("security", [{"bearer": []}])
            for response in operation.get("responses", {}).values():
                content = response.get("content", {})
                if len(content) > 1 and not content.get("application/json", {}).get("schema", True):
                    del content["application/json"]
    return schema


# ---- the interactive pages, served offline ---------------------------------------------------------------------------
#: Swagger UI / ReDoc assets shipped by the fastapi-offline package (swagger-ui-bundle.js, swagger-ui.css,
#: redoc.standalone.js), served under ASSETS_URL; the Swagger UI start-up script is api/static/apidocs/swagger-init.js
ASSETS_URL = "/docs/assets"
#: the docs pages load scripts and styles from this server only; both UIs inject <style> elements (inline styles),
#: ReDoc runs its search index in a blob: worker
DOCS_PAGE_CSP = ("default-src 'none'; script-src 'self'; style-src 'self' 'unsafe-inline'; img-src 'self' data:; "
                 "font-src 'self' data:; connect-src 'self'; worker-src 'self' blob:; base-uri 'none'; "
                 "form-action 'none'; frame-ancestors 'none'")

SWAGGER_PAGE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{title} - Swagger UI</title>
<link rel="icon" type="image/png" href="{root}{assets}/favicon.png">
<link rel="stylesheet" href="{root}{assets}/swagger-ui.css">
</head>
<body>
<div id="swagger-ui" data-openapi-url="{root}{openapi}"></div>
<script src="{root}{assets}/swagger-ui-bundle.js"></script>
<script src="{root}/static/apidocs/swagger-init.js"></script>
</body>
</html>
"""


def assets_dir() -> str:
    """Folder of the Swagger UI / ReDoc files inside the installed fastapi-offline package."""
    import importlib.util
    from pathlib import Path

    spec = importlib.util.find_spec("fastapi_offline")
    if spec is None or not spec.submodule_search_locations:
        raise RuntimeError("the fastapi-offline package (Swagger UI / ReDoc assets) is not installed")
    return str(Path(next(iter(spec.submodule_search_locations))) / "static")


def install_docs(app: Any) -> None:
    """Serve /docs (Swagger UI) and /redoc (ReDoc) from local assets only (the app is built with docs_url=None)."""
    app.mount(ASSETS_URL, StaticFiles(directory=assets_dir()), name="docs-assets")
    headers = {"Content-Security-Policy": DOCS_PAGE_CSP}

    @app.get("/docs", include_in_schema=False)
    def swagger_ui(request: Request) -> HTMLResponse:
        root = request.scope.get("root_path", "")
        page = SWAGGER_PAGE.format(title=app.title, root=root, assets=ASSETS_URL, openapi=app.openapi_url)
        return HTMLResponse(page, headers=headers)

    @app.get("/redoc", include_in_schema=False)
    def redoc(request: Request) -> HTMLResponse:
        root = request.scope.get("root_path", "")
        page = get_redoc_html(openapi_url=f"{root}{app.openapi_url}", title=f"{app.title} - ReDoc",
                              redoc_js_url=f"{root}{ASSETS_URL}/redoc.standalone.js",
                              redoc_favicon_url=f"{root}{ASSETS_URL}/favicon.png", with_google_fonts=False)
        page.headers.update(headers)
        return page


def untyped_responses(schema: dict[str, Any]) -> list[str]:
    """'METHOD path status' of every JSON response whose schema gives no shape (absent, a bare object, or an
    array of those): ``python -c "from api.openapi import *; ..."`` in docs/service.md counts them."""

    def untyped(s: dict[str, Any] | None) -> bool:
        if not s:
            return True
        if "$ref" in s:
            return False
        if "anyOf" in s:
            return any(untyped(x) for x in s["anyOf"] if x.get("type") != "null")
        if s.get("type") == "array":
            return untyped(s.get("items"))
        extra = s.get("additionalProperties")
        return s.get("type") == "object" and not s.get("properties") and not (isinstance(extra, dict) and
                                                                               not untyped(extra))

    return [f"{method.upper()} {path} {status}" for path, ops in schema.get("paths", {}).items()
            for method, op in ops.items() for status, response in op.get("responses", {}).items()
            if "application/json" in response.get("content", {})
            and untyped(response["content"]["application/json"].get("schema"))]
