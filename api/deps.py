"""Shared dependencies of the API routes: the service context (settings, store, Celery) and API-key auth."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from fastapi import Request

from api.problems import Problem, invalid
from romams.keys import ApiKey, match
from romams.persistence import Store
from romams.settings import Settings

WING_NAME_MAX = 200  # the wings.name column


@dataclass
class Service:
    """What a request handler needs: settings, the store and the Celery app used to send tasks."""

    settings: Settings
    store: Store
    celery: Any
    wings: dict[str, tuple[int, Any]] = field(default_factory=dict)  # stored wings never change: cached by ref


def service(request: Request) -> Service:
    """The app's service context."""
    return request.app.state.service


def key_problem(keys: list[ApiKey], authorization: str, scope: str = "write") -> Problem | None:
    """The 401/403 problem of an ``Authorization`` header that does not carry a configured key granting ``scope``
    (None when it does, or when no key is configured). Keys are compared by hash, in constant time."""
    if not keys:
        return None
    scheme, _, token = authorization.partition(" ")
    if scheme.lower() != "bearer" or not token.strip():
        return Problem(401, "authorization: a Bearer API key is required for this endpoint", "authorization",
                       headers={"WWW-Authenticate": "Bearer"})
    key = match(keys, token.strip())
    if key is None:
        return Problem(403, "authorization: the API key is not valid", "authorization")
    if not key.allows(scope):
        return Problem(403, f"authorization: the API key has the {key.scope} scope; this endpoint needs {scope}",
                       "authorization")
    return None


def key_of(keys: list[ApiKey], authorization: str) -> ApiKey | None:
    """The configured key an ``Authorization: Bearer`` header carries, or None."""
    scheme, _, token = authorization.partition(" ")
    return match(keys, token.strip()) if scheme.lower() == "bearer" and token.strip() else None


def require_key(request: Request) -> None:
    """Mutating endpoints: ``Authorization: Bearer <key>`` must carry a write key (if keys are configured). The
    request guard (api.middleware) makes the same check before the body is read; this one documents it per route."""
    problem = key_problem(request.app.state.service.settings.api_keys, request.headers.get("authorization", ""))
    if problem is not None:
        raise problem


def single_query_values(request: Request) -> None:
    """A declared query parameter given more than once is a 422 naming it: the API has no list-valued query
    parameter, and Starlette would silently take the last of them."""
    dependant = getattr(request.scope.get("route"), "dependant", None)
    for param in getattr(dependant, "query_params", ()):
        if len(request.query_params.getlist(param.alias)) > 1:
            raise invalid(param.alias, "given more than once")


def no_nul(value: Any, field: str) -> Any:
    """``value`` unchanged unless a string in it (a key or a value of a nested JSON object, at any depth) holds a
    NUL character, which PostgreSQL text cannot store: then 422 naming the place (``field`` + the path inside)."""
    stack: list[tuple[str, Any]] = [(field, value)]
    while stack:
        path, v = stack.pop()
        if isinstance(v, str):
            if "\x00" in v:
                raise invalid(path, "must not contain NUL characters")
        elif isinstance(v, dict):
            for k, x in v.items():
                if isinstance(k, str) and "\x00" in k:
                    raise invalid(path, "a key must not contain NUL characters")
                stack.append((f"{path}.{k}", x))
        elif isinstance(v, list | tuple):
            stack.extend((f"{path}[{i}]", x) for i, x in enumerate(v))
    return value


def form_int(text: dict[str, str], key: str, lo: int, hi: int) -> int | None:
    """An optional integer text field of a multipart form, in [lo, hi] (None when absent or empty; 422 naming it
    otherwise)."""
    if not text.get(key):
        return None
    if not text[key].isdigit() or not lo <= int(text[key]) <= hi:
        raise invalid(key, f"must be an integer in [{lo}, {hi}], got {text[key][:20]!r}")
    return int(text[key])


def wing_or_404(svc: Service, wing_ref: str) -> tuple[int, Any]:
    """(id, WingDefinition) by id or name, else 404 naming the wing (a found wing is cached: wings are immutable).
    An id beyond the id columns' range, or a name longer than a stored one can be, is not looked up: 404."""
    hit = svc.wings.get(wing_ref)
    if hit is not None:
        return hit
    no_nul(wing_ref, "wing")
    if len(wing_ref) > WING_NAME_MAX:
        raise Problem(404, f"wing: no wing with id or name {wing_ref[:80]!r}...", "wing")
    try:
        found = svc.store.wings.find(wing_ref)
    except ValueError as exc:  # a stored definition the current code cannot read
        raise Problem(409, f"wing: stored definition of {wing_ref!r} cannot be loaded: {exc}", "wing") from exc
    if found is None:
        raise Problem(404, f"wing: no wing with id or name {wing_ref!r}", "wing")
    if len(svc.wings) < 1024:
        svc.wings[wing_ref] = found
    return found
