"""ASGI middleware of the API: security headers on every response, and the checks made before a body is read.

``SecurityHeaders`` wraps the whole application (also the 500 page of Starlette's error middleware):
Content-Security-Policy, X-Frame-Options, X-Content-Type-Options and Referrer-Policy on every response.
``RequestGuard`` runs before a route reads its body: the API key of a request under ``/api/`` (a write key for a
mutating one, a read key for the others, when keys are configured; ``/api/v1/health`` stays open), so that a large
body without a valid key is refused unread; the evaluation rate limit (429, api.ratelimit); and the body size (413
on the declared Content-Length before anything is read, and while a body without one streams in). Both are plain
ASGI (no buffering of bodies).
"""

from __future__ import annotations

import re
from typing import Any

import anyio.to_thread
from starlette.datastructures import Headers, MutableHeaders
from starlette.exceptions import HTTPException
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from api.problems import Problem, problem_response
from api.ratelimit import make_limiter, retry_after

#: the dashboard and every API response: own scripts, styles and images only (the dashboard has no inline script
#: or style; its progress bars are sized through the CSSOM; with keys configured it fetches its plots with the key
#: and shows them as blob: URLs), fetches to this origin, no framing
CSP = ("default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self' data: blob:; connect-src 'self'; "
       "base-uri 'none'; form-action 'none'; frame-ancestors 'none'")
#: the interactive OpenAPI pages (/docs, /redoc) and their assets, all served from the package (api/openapi.py sets
#: the same policy on the two pages): own scripts only, the inline styles Swagger UI and ReDoc inject, ReDoc's worker
DOCS_CSP = ("default-src 'none'; script-src 'self'; style-src 'self' 'unsafe-inline'; img-src 'self' data:; "
            "font-src 'self' data:; connect-src 'self'; worker-src 'self' blob:; base-uri 'none'; "
            "form-action 'none'; frame-ancestors 'none'")
HEADERS = {"X-Frame-Options": "DENY", "X-Content-Type-Options": "nosniff", "Referrer-Policy": "no-referrer"}
DOCS_PREFIXES = ("/docs", "/redoc")
MUTATING = frozenset({"POST", "PUT", "PATCH", "DELETE"})
UPLOAD_PATHS = frozenset({"/api/v1/modes"})
#: paths whose multipart bodies (a Nastran deck upload) get the upload limit; their JSON bodies keep request_max_bytes
MULTIPART_UPLOAD_PATHS = frozenset({"/api/v1/wings"})
OPEN_PATHS = frozenset({"/api/v1/health"})
#: the evaluation endpoints under the rate limit
RATE_LIMITED = re.compile(r"/api/v1/wings/[^/]+/flutter(/batch)?/?")


class SecurityHeaders:
    """Adds the security headers to every HTTP response (a header the route set itself is kept)."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        csp = DOCS_CSP if str(scope.get("path", "")).startswith(DOCS_PREFIXES) else CSP

        async def send_with_headers(message: Message) -> None:
            if message["type"] == "http.response.start":
                headers = MutableHeaders(scope=message)
                headers.setdefault("Content-Security-Policy", csp)
                for name, value in HEADERS.items():
                    headers.setdefault(name, value)
            await send(message)

        await self.app(scope, receive, send_with_headers)


class BodyTooLarge(HTTPException):
    """Raised while a request body streams in past its limit (FastAPI passes HTTPExceptions through)."""

    def __init__(self, limit: int) -> None:
        super().__init__(413, f"body: larger than {limit} bytes")
        self.limit = limit


class RequestGuard:
    """API key and scope, evaluation rate limit and request body size, all checked before the body is read.

    ``settings``: the service settings (``api_keys``, ``rate_limit_*``, ``request_max_bytes``, ``upload_max_bytes``).
    """

    def __init__(self, app: ASGIApp, settings: Any) -> None:
        self.app = app
        self.settings = settings
        self.limiter = make_limiter(settings)

    def limit(self, path: str, content_type: str = "") -> int:
        """Largest body of a request to ``path`` (the modes upload: two files and the multipart framing)."""
        if path in UPLOAD_PATHS or (path in MULTIPART_UPLOAD_PATHS
                                    and content_type.lower().startswith("multipart/form-data")):
            return 2 * int(self.settings.upload_max_bytes) + 1024 * 1024
        return int(self.settings.request_max_bytes)

    def key_check(self, method: str, path: str, headers: Headers) -> Problem | None:
        """401/403 of a request under ``/api/`` without a key of the scope it needs (write to mutate, else read)."""
        from api.deps import key_problem

        keys = self.settings.api_keys
        if not keys or not path.startswith("/api/") or path in OPEN_PATHS:
            return None
        return key_problem(keys, headers.get("authorization", ""), "write" if method in MUTATING else "read")

    async def rate_check(self, scope: Scope, method: str, path: str, headers: Headers) -> Problem | None:
        """429 of an evaluation request whose bucket (its key, or its client address without keys) is empty."""
        if self.limiter is None or method != "POST" or not RATE_LIMITED.fullmatch(path):
            return None
        from api.deps import key_of

        key = key_of(self.settings.api_keys, headers.get("authorization", "")) if self.settings.api_keys else None
        client = scope.get("client") or ("unknown", 0)
        bucket = f"key:{key.id}" if key is not None else f"ip:{client[0]}"
        if self.limiter.backend == "redis":
            wait = await anyio.to_thread.run_sync(self.limiter.take, bucket)
        else:
            wait = self.limiter.take(bucket)
        if wait <= 0:
            return None
        return Problem(429, f"rate limit: at most {self.settings.rate_limit_per_s:g} evaluation requests per second "
                       f"(burst {self.settings.rate_burst}) per API key; retry after {wait:.2f} s", None,
                       headers={"Retry-After": retry_after(wait)})

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        path = str(scope.get("path", ""))
        method = str(scope.get("method", ""))
        headers = Headers(scope=scope)
        problem = self.key_check(method, path, headers) or await self.rate_check(scope, method, path, headers)
        if problem is not None:
            await problem_response(problem.status, problem.detail, title=problem.title, field=problem.field,
                                   instance=path, headers=problem.headers)(scope, receive, send)
            return
        limit = self.limit(path, headers.get("content-type", ""))
        declared = headers.get("content-length")
        if declared is not None:
            try:
                size = int(declared)
            except ValueError:
                size = -1
            if size < 0:
                await problem_response(400, "content-length: not a byte count", field="content-length",
                                       instance=path)(scope, receive, send)
                return
            if size > limit:
                await self._too_large(scope, receive, send, limit)
                return
        state = {"received": 0, "exceeded": False, "started": False, "replaced": False}

        async def receive_limited() -> Message:
            message = await receive()
            if message["type"] == "http.request":
                state["received"] += len(message.get("body", b""))
                if state["received"] > limit:
                    state["exceeded"] = True
                    raise BodyTooLarge(limit)
            return message

        async def send_checked(message: Message) -> None:
            if state["replaced"]:
                return  # the app's answer to the aborted read, replaced by the 413
            if message["type"] == "http.response.start":
                if state["exceeded"]:  # whatever the app made of the aborted read (e.g. a 400): a 413
                    state["replaced"] = True
                    await self._too_large(scope, receive, send, limit)
                    return
                state["started"] = True
            await send(message)

        try:
            await self.app(scope, receive_limited, send_checked)
        except BodyTooLarge:
            if state["started"]:
                raise
            if not state["replaced"]:
                await self._too_large(scope, receive, send, limit)

    @staticmethod
    async def _too_large(scope: Scope, receive: Receive, send: Send, limit: int) -> None:
        """413 problem naming the body and the limit."""
        detail = (f"body: larger than {limit} bytes (the request body limit; request_max_bytes, or upload_max_bytes "
                  f"per file of a modes upload)")
        await problem_response(413, detail, field="body", instance=str(scope.get("path", "")),
                               headers={"Connection": "close"})(scope, receive, send)
