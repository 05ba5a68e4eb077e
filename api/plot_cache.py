"""PNG/SVG responses of the plot routes, cached by the content hash of what they draw, with an ETag.

The key (``romams.plots.cache.plot_key``) is the hash of the data a figure draws and its options (format, kind,
axis ...); the rendered bytes are kept in the app's bounded LRU (``app.state.plot_cache``), and the key is the
response's ETag: a browser revalidating with If-None-Match gets a 304 without a body, and a new request for the
same data gets the cached bytes without rendering. ``Cache-Control: no-cache`` makes browsers revalidate, so a
changed figure (new data, new key) is never served stale.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from fastapi import Request, Response

from romams.plots.cache import PlotCache, plot_key

NOT_MODIFIED: dict[int | str, dict[str, Any]] = {
    304: {"description": "not modified: the plot's ETag matches If-None-Match (the data drawn has not changed)",
          "headers": {"ETag": {"description": "content hash of the data drawn and the plot options",
                               "schema": {"type": "string"}}}}}
MEDIA_TYPES = {"png": "image/png", "svg": "image/svg+xml"}
DPI = 100


def plot_cache(request: Request) -> PlotCache:
    """The app's plot cache (created on first use)."""
    state = request.app.state
    cache = getattr(state, "plot_cache", None)
    if cache is None:
        cache = state.plot_cache = PlotCache()
    return cache


def etag_matches(header: str | None, etag: str) -> bool:
    """True when an If-None-Match header lists ``etag`` (weak or strong) or is ``*``."""
    if not header:
        return False
    tags = [t.strip().removeprefix("W/") for t in header.split(",")]
    return "*" in tags or etag in tags


def plot_response(request: Request, fmt: str, parts: tuple[Any, ...], draw: Callable[[], Any]) -> Response:
    """The image of ``draw()`` (a matplotlib Figure) in ``fmt``, keyed by the hash of ``parts`` (the data drawn
    and the plot options): 304 when If-None-Match has its ETag, else the cached or newly rendered bytes."""
    from romams.plots.flutter import figure_bytes

    key = plot_key(fmt, *parts)
    etag = f'"{key[:32]}"'
    headers = {"ETag": etag, "Cache-Control": "no-cache"}
    if etag_matches(request.headers.get("if-none-match"), etag):
        return Response(status_code=304, headers=headers)
    data = plot_cache(request).render(key, lambda: figure_bytes(draw(), fmt, dpi=DPI))
    return Response(data, media_type=MEDIA_TYPES[fmt], headers=headers)
