"""Shared dependencies of the API routes: the service context (settings, store, Celery) and API-key auth."""

from __future__ import annotations

import hmac
from dataclasses import dataclass, field
from typing import Any

from fastapi import Request

from api.problems import Problem
from romams.persistence import Store
from romams.settings import Settings


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


def require_key(request: Request) -> None:
    """Mutating endpoints: ``Authorization: Bearer <key>`` must match a configured key (if any are)."""
    keys = request.app.state.service.settings.api_keys
    if not keys:
        return
    auth = request.headers.get("authorization", "")
    scheme, _, token = auth.partition(" ")
    if scheme.lower() != "bearer" or not token:
        raise Problem(401, "authorization: a Bearer API key is required for this endpoint", "authorization",
                      headers={"WWW-Authenticate": "Bearer"})
    if not any(hmac.compare_digest(token.strip().encode(), k.encode()) for k in keys):
        raise Problem(403, "authorization: the API key is not valid", "authorization")


def wing_or_404(svc: Service, wing_ref: str) -> tuple[int, Any]:
    """(id, WingDefinition) by id or name, else 404 naming the wing (a found wing is cached: wings are immutable)."""
    hit = svc.wings.get(wing_ref)
    if hit is not None:
        return hit
    try:
        found = svc.store.wings.find(wing_ref)
    except ValueError as exc:  # a stored definition the current code cannot read
        raise Problem(409, f"wing: stored definition of {wing_ref!r} cannot be loaded: {exc}", "wing") from exc
    if found is None:
        raise Problem(404, f"wing: no wing with id or name {wing_ref!r}", "wing")
    if len(svc.wings) < 1024:
        svc.wings[wing_ref] = found
    return found
