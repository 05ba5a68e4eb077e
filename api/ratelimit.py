"""Token-bucket rate limit of the evaluation endpoints, per API key (or per client address without keys).

A bucket holds at most ``burst`` tokens and refills at ``rate`` tokens per second; a request takes one token or
waits ``(1 - tokens) / rate`` seconds (its ``Retry-After``). With a Redis broker the buckets live in Redis (one
hash per bucket, updated by one Lua script on the server's clock), so every API process of a deployment shares
them; otherwise (embedded mode, one API process) they live in the process. If Redis cannot be reached, the
process falls back to its own buckets for ``REDIS_RETRY_S`` seconds instead of refusing or stalling requests.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections import OrderedDict
from typing import Any, Protocol

log = logging.getLogger(__name__)
REDIS_RETRY_S = 5.0
LOCAL_BUCKETS_MAX = 10_000  # least recently used buckets beyond this are dropped (a full bucket is the default)

#: KEYS[1] bucket hash; ARGV rate (tokens/s), burst (tokens). Returns the wait in seconds (as text: Lua numbers
#: become integers on the way back), 0 when a token was taken.
LUA = """
local rate = tonumber(ARGV[1])
local burst = tonumber(ARGV[2])
local t = redis.call('TIME')
local now = tonumber(t[1]) + tonumber(t[2]) / 1e6
local s = redis.call('HMGET', KEYS[1], 'tokens', 'ts')
local tokens = tonumber(s[1])
local ts = tonumber(s[2])
if tokens == nil or ts == nil then tokens = burst; ts = now end
tokens = math.min(burst, tokens + math.max(0, now - ts) * rate)
local wait = 0
if tokens >= 1 then tokens = tokens - 1 else wait = (1 - tokens) / rate end
redis.call('HSET', KEYS[1], 'tokens', tostring(tokens), 'ts', tostring(now))
redis.call('EXPIRE', KEYS[1], math.ceil(burst / rate) + 1)
return tostring(wait)
"""


class Limiter(Protocol):
    """Takes a token from a bucket: the seconds to wait before a token is there (0: taken)."""

    backend: str

    def take(self, bucket: str) -> float: ...


class LocalLimiter:
    """Token buckets in this process (thread-safe)."""

    backend = "process"

    def __init__(self, rate: float, burst: int) -> None:
        self.rate, self.burst = float(rate), float(burst)
        self._buckets: OrderedDict[str, tuple[float, float]] = OrderedDict()
        self._lock = threading.Lock()

    def take(self, bucket: str) -> float:
        """Seconds to wait for a token of ``bucket`` (0: one was taken)."""
        now = time.monotonic()
        with self._lock:
            tokens, ts = self._buckets.pop(bucket, (self.burst, now))
            tokens = min(self.burst, tokens + (now - ts) * self.rate)
            wait = 0.0
            if tokens >= 1:
                tokens -= 1
            else:
                wait = (1 - tokens) / self.rate
            self._buckets[bucket] = (tokens, now)
            if len(self._buckets) > LOCAL_BUCKETS_MAX:
                self._buckets.popitem(last=False)
        return wait


class RedisLimiter:
    """Token buckets in Redis, shared by every API process; the local buckets while Redis is unreachable."""

    backend = "redis"

    def __init__(self, url: str, rate: float, burst: int, prefix: str = "romams:ratelimit:") -> None:
        import redis

        self.rate, self.burst, self.prefix = float(rate), int(burst), prefix
        self._redis = redis.Redis.from_url(url, socket_timeout=0.5, socket_connect_timeout=0.5)
        self._script: Any = self._redis.register_script(LUA)
        self._local = LocalLimiter(rate, burst)
        self._down_until = 0.0

    def take(self, bucket: str) -> float:
        """Seconds to wait for a token of ``bucket`` (0: one was taken)."""
        if time.monotonic() < self._down_until:
            return self._local.take(bucket)
        try:
            return float(self._script(keys=[self.prefix + bucket], args=[self.rate, self.burst]))
        except Exception as exc:  # noqa: BLE001 - any Redis failure: the process's own buckets for a while
            log.warning("rate limit: Redis unavailable (%s); per-process buckets for %.0f s",
                        type(exc).__name__, REDIS_RETRY_S)
            self._down_until = time.monotonic() + REDIS_RETRY_S
            return self._local.take(bucket)


def make_limiter(settings: Any) -> Limiter | None:
    """The evaluation rate limiter of ``settings`` (None when ``rate_limit_per_s`` is 0): in Redis when the
    broker is Redis, else in the process."""
    if settings.rate_limit_per_s <= 0:
        return None
    if settings.broker.startswith(("redis://", "rediss://")):
        return RedisLimiter(settings.broker, settings.rate_limit_per_s, settings.rate_burst)
    return LocalLimiter(settings.rate_limit_per_s, settings.rate_burst)


def retry_after(wait_s: float) -> str:
    """``Retry-After`` value (whole seconds, at least 1) of a wait."""
    return str(max(1, math.ceil(wait_s)))
