"""API keys of the service: scopes, the hashed form they are stored in, and the constant-time check.

A configured key entry is one of
  ``sha256:<64 hex digits>``            the SHA-256 of a key (scope ``write``),
  ``sha256:<64 hex digits>:<scope>``    the same with a scope, ``read`` or ``write``,
  ``<plain key>`` or ``<plain key>:<scope>``  a key in plain text (accepted for compatibility: it is hashed
                                        when the settings are loaded, and only its hash is kept).
``romams keys new`` makes a random key and prints its entry; ``romams keys hash`` prints the entry of a given key.
``write`` includes ``read``. Keys are high-entropy random strings, so an unsalted SHA-256 is enough to keep them
out of settings files and process memory dumps (what a password hash adds, slowness, defends weak secrets).
"""

from __future__ import annotations

import hashlib
import hmac
import re
import secrets
from dataclasses import dataclass, field

SCOPES = ("read", "write")
HASHED = re.compile(r"sha256:([0-9a-fA-F]{64})(?::(\w+))?")


@dataclass(frozen=True)
class ApiKey:
    """A configured key: the SHA-256 digest of its text (hex) and its scope (never the key itself)."""

    digest: str = field(repr=False)
    scope: str = "write"

    @property
    def id(self) -> str:
        """Short public id of the key (12 hex digits of its hash): rate-limit buckets and log lines."""
        return self.digest[:12]

    def allows(self, scope: str) -> bool:
        """True when this key grants ``scope`` (``write`` grants ``read``)."""
        return SCOPES.index(self.scope) >= SCOPES.index(scope)

    def entry(self) -> str:
        """The settings entry of this key (``sha256:<hex>:<scope>``)."""
        return f"sha256:{self.digest}:{self.scope}"

    def __repr__(self) -> str:
        return f"ApiKey(id={self.id!r}, scope={self.scope!r})"


def digest(key: str) -> str:
    """SHA-256 digest (lower-case hex) of a key's UTF-8 text."""
    return hashlib.sha256(key.encode()).hexdigest()


def _scope(value: str | None, entry_hint: str) -> str:
    """A checked scope name (default ``write``)."""
    scope = (value or "write").lower()
    if scope not in SCOPES:
        raise ValueError(f"api_keys: unknown scope {scope!r} in {entry_hint} (known: {', '.join(SCOPES)})")
    return scope


def parse_key(entry: str) -> ApiKey:
    """An ApiKey from a settings entry (hashed or plain, see the module doc). The error names no plain key."""
    entry = entry.strip()
    m = HASHED.fullmatch(entry)
    if m:
        return ApiKey(m.group(1).lower(), _scope(m.group(2), "a sha256 entry"))
    if entry.lower().startswith("sha256:"):
        raise ValueError("api_keys: a sha256 entry must be sha256:<64 hex digits>[:read|:write]")
    head, sep, tail = entry.rpartition(":")
    if sep and head and tail.lower() in SCOPES:
        return ApiKey(digest(head), tail.lower())
    if not entry:
        raise ValueError("api_keys: an empty key")
    return ApiKey(digest(entry))


def parse_keys(value: object) -> object:
    """Settings input (a comma/newline separated string, a list of entries or ApiKeys) as a list of ApiKeys."""
    if isinstance(value, str):
        value = [k for k in re.split(r"[,\n]", value) if k.strip() and not k.strip().startswith("#")]
    if isinstance(value, list | tuple):
        return [k if isinstance(k, ApiKey) else parse_key(str(k)) for k in value]
    return value


def match(keys: list[ApiKey], token: str) -> ApiKey | None:
    """The configured key whose hash is the hash of ``token``, or None. Every key is compared, each in constant
    time, so the answer's timing says nothing about which key or how much of it matched."""
    d = digest(token).encode()
    found = None
    for k in keys:
        if hmac.compare_digest(d, k.digest.encode()):
            found = k
    return found


def new_key() -> str:
    """A fresh random key (256 bits, URL-safe text)."""
    return secrets.token_urlsafe(32)
