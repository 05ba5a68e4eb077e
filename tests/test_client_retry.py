"""Retry logic of RomamsClient (httpx.MockTransport: a real server cannot be made to fail on cue).

Everything else of the client is tested against the real service in test_client.py.
"""

from __future__ import annotations

import httpx
import pytest

from client import RomamsClient, RomamsError

PROBLEM = "application/problem+json"


def _client(handler, retries: int = 5, backoff: float = 0.5, max_backoff: float = 10.0):
    """Client on a MockTransport whose backoff sleeps are recorded instead of slept."""
    sleeps: list[float] = []
    c = RomamsClient("http://svc.test", api_key="k1", retries=retries, backoff=backoff, max_backoff=max_backoff,
                     transport=httpx.MockTransport(handler), sleep=sleeps.append)
    return c, sleeps


def _unavailable(retry_after: str | None = None) -> httpx.Response:
    headers = {"retry-after": retry_after} if retry_after else {}
    return httpx.Response(503, headers=headers, json={"type": "about:blank", "title": "Service Unavailable",
                                                      "status": 503, "detail": "database: busy"})


def test_503_is_retried_with_exponential_backoff() -> None:
    calls = []

    def handler(request: httpx.Request) -> httpx.Response:
        calls.append(request)
        if len(calls) <= 3:
            return _unavailable()
        return httpx.Response(200, json={"status": "ok", "version": "x", "database": "sqlite"})

    c, sleeps = _client(handler)
    assert c.health()["status"] == "ok"
    assert len(calls) == 4
    assert sleeps == [0.5, 1.0, 2.0]  # backoff * 2**attempt
    assert c.retried == 3 and c.requests_sent == 4
    assert all(r.headers["authorization"] == "Bearer k1" for r in calls)


def test_backoff_is_capped_and_retry_after_is_honoured() -> None:
    n = {"i": 0}

    def handler(request: httpx.Request) -> httpx.Response:
        n["i"] += 1
        if n["i"] == 1:
            return _unavailable(retry_after="7")
        if n["i"] < 6:
            return _unavailable()
        return httpx.Response(201, json={"id": 3})

    c, sleeps = _client(handler, retries=6, backoff=1.0, max_backoff=4.0)
    assert c.create_wing("cropped-delta", "w") == 3
    assert sleeps == [7.0, 2.0, 4.0, 4.0, 4.0]  # Retry-After 7 s beats the 1 s backoff; then 2, 4, capped at 4


def test_connection_errors_are_retried() -> None:
    n = {"i": 0}

    def handler(request: httpx.Request) -> httpx.Response:
        n["i"] += 1
        if n["i"] <= 2:
            raise httpx.ConnectError("connection refused", request=request)
        return httpx.Response(200, json={"id": "j1", "status": "succeeded"})

    c, sleeps = _client(handler)
    assert c.get_job("j1")["status"] == "succeeded"
    assert sleeps == [0.5, 1.0]


def test_retries_exhausted_raise_the_last_problem() -> None:
    c, sleeps = _client(lambda r: _unavailable(), retries=2)
    with pytest.raises(RomamsError) as ei:
        c.health()
    assert ei.value.status == 503
    assert ei.value.detail == "database: busy"
    assert len(sleeps) == 2


def test_connection_failure_after_retries_is_status_0() -> None:
    def handler(request: httpx.Request) -> httpx.Response:
        raise httpx.ConnectError("connection refused", request=request)

    c, sleeps = _client(handler, retries=3)
    with pytest.raises(RomamsError) as ei:
        c.list_wings()
    assert ei.value.status == 0
    assert "ConnectError" in ei.value.detail
    assert sleeps == [0.5, 1.0, 2.0]


def test_client_errors_are_not_retried() -> None:
    calls = []

    def handler(request: httpx.Request) -> httpx.Response:
        calls.append(request)
        return httpx.Response(422, headers={"content-type": PROBLEM},
                              json={"type": "about:blank", "title": "Unprocessable Content", "status": 422,
                                    "detail": "design.x1: 0.9 is outside its bounds [0.15, 0.7]",
                                    "field": "design.x1"})

    c, sleeps = _client(handler)
    with pytest.raises(RomamsError) as ei:
        c.evaluate(1, [0.9] * 7)
    assert len(calls) == 1 and sleeps == []
    assert (ei.value.status, ei.value.field) == (422, "design.x1")


def test_rejects_negative_retries() -> None:
    with pytest.raises(ValueError, match="retries"):
        RomamsClient("http://svc.test", retries=-1)
