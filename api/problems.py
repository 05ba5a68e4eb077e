"""RFC 9457 problem details: every error of the API is ``application/problem+json``.

Validation errors name the offending field (``field``: a dotted path into the request) and the
reason; the core's ``ValueError`` messages already start with the field name.
"""

from __future__ import annotations

import logging
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException as StarletteHTTPException

PROBLEM_JSON = "application/problem+json"
METHODS = ("GET", "HEAD", "POST", "PUT", "PATCH", "DELETE")
log = logging.getLogger("romams.api")

TITLES = {400: "Bad Request", 401: "Unauthorized", 403: "Forbidden", 404: "Not Found", 405: "Method Not Allowed",
          409: "Conflict", 413: "Content Too Large", 415: "Unsupported Media Type", 422: "Unprocessable Content",
          429: "Too Many Requests",
          500: "Internal Server Error", 501: "Not Implemented", 503: "Service Unavailable", 504: "Gateway Timeout"}


class Problem(Exception):
    """An HTTP error with a problem+json body (``field`` names the offending input)."""

    def __init__(self, status: int, detail: str, field: str | None = None, *, title: str | None = None,
                 extra: dict[str, Any] | None = None, headers: dict[str, str] | None = None) -> None:
        super().__init__(detail)
        self.status, self.detail, self.field = status, detail, field
        self.title = title or TITLES.get(status, "Error")
        self.extra = extra or {}
        self.headers = headers


def invalid(field: str, reason: str) -> Problem:
    """422 for an invalid request field."""
    return Problem(422, f"{field}: {reason}", field)


def from_value_error(exc: ValueError, prefix: str = "") -> Problem:
    """422 from a core error, the field nested under the request path ``prefix`` (services.errors rule)."""
    from romams.services.errors import from_input_error

    err = from_input_error(exc, prefix or None)
    return Problem(err.status, err.detail, err.field)


def problem_response(status: int, detail: str, *, title: str | None = None, field: str | None = None,
                     instance: str | None = None, extra: dict[str, Any] | None = None,
                     headers: dict[str, str] | None = None) -> JSONResponse:
    """A problem+json response."""
    body: dict[str, Any] = {"type": "about:blank", "title": title or TITLES.get(status, "Error"), "status": status,
                            "detail": detail}
    if field:
        body["field"] = field
    if instance:
        body["instance"] = instance
    body.update(extra or {})
    return JSONResponse(body, status_code=status, media_type=PROBLEM_JSON, headers=headers)


def _loc(loc: tuple[Any, ...] | list[Any]) -> str:
    """Dotted field path of a pydantic error location (without the leading 'body')."""
    out = ""
    for p in loc:
        if p in ("body", "query", "path", "header") or (isinstance(p, str) and ("[" in p or p.startswith("function"))):
            continue  # location roots and pydantic's union-member tags
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
    return out or "body"


def allowed_methods(request: Request) -> str:
    """The ``Allow`` header of a 405: every method some route of the app fully matches for the request's path."""
    from starlette.routing import Match

    allowed = []
    for method in METHODS:
        scope = {**request.scope, "method": method}
        if any(route.matches(scope)[0] == Match.FULL for route in request.app.router.routes):
            allowed.append(method)
    return ", ".join(allowed)


def install(app: FastAPI) -> None:
    """Register the problem+json handlers on ``app``."""

    @app.exception_handler(Problem)
    async def _problem(request: Request, exc: Problem) -> JSONResponse:
        return problem_response(exc.status, exc.detail, title=exc.title, field=exc.field,
                                instance=str(request.url.path), extra=exc.extra, headers=exc.headers)

    @app.exception_handler(RequestValidationError)
    async def _validation(request: Request, exc: RequestValidationError) -> JSONResponse:
        errors = [{"field": _loc(e.get("loc", ())), "reason": e.get("msg", "invalid")} for e in exc.errors()]
        # the most specific error first (for a union such as design = dict | list, the branch that got deepest)
        ranked = sorted(range(len(errors)), key=lambda i: -len(exc.errors()[i].get("loc", ())))
        first = errors[ranked[0]] if errors else {"field": "body", "reason": "invalid request"}
        return problem_response(422, f"{first['field']}: {first['reason']}", field=first["field"],
                                instance=str(request.url.path), extra={"errors": errors})

    @app.exception_handler(StarletteHTTPException)
    async def _http(request: Request, exc: StarletteHTTPException) -> JSONResponse:
        headers = getattr(exc, "headers", None)
        if exc.status_code == 405:  # Starlette names the methods of the first route of the path only
            headers = {**(headers or {}), "Allow": allowed_methods(request)}
        return problem_response(exc.status_code, str(exc.detail), instance=str(request.url.path), headers=headers)

    from romams.jobs import BrokerUnavailable
    from romams.persistence import DatabaseUnavailable
    from romams.services.errors import ServiceError, from_input_error
    from romams_core.errors import InputError

    def retry_after(request: Request) -> dict[str, str]:
        service = getattr(request.app.state, "service", None)
        return {"Retry-After": str(getattr(getattr(service, "settings", None), "retry_after_s", 5))}

    @app.exception_handler(ServiceError)
    async def _service(request: Request, exc: ServiceError) -> JSONResponse:
        return problem_response(exc.status, exc.detail, field=exc.field, instance=str(request.url.path),
                                extra=exc.extra)

    @app.exception_handler(InputError)
    async def _input(request: Request, exc: InputError) -> JSONResponse:
        err = from_input_error(exc)
        return problem_response(err.status, err.detail, field=err.field, instance=str(request.url.path))

    @app.exception_handler(BrokerUnavailable)
    async def _broker(request: Request, exc: BrokerUnavailable) -> JSONResponse:
        return problem_response(503, str(exc), instance=str(request.url.path), headers=retry_after(request))

    @app.exception_handler(DatabaseUnavailable)
    async def _database(request: Request, exc: DatabaseUnavailable) -> JSONResponse:
        log.warning("database unavailable on %s: %s", request.url.path, exc)
        return problem_response(503, str(exc), instance=str(request.url.path), headers=retry_after(request))

    @app.exception_handler(Exception)
    async def _unexpected(request: Request, exc: Exception) -> JSONResponse:
        log.exception("unhandled error on %s", request.url.path)
        return problem_response(500, f"internal error: {type(exc).__name__}", instance=str(request.url.path))
