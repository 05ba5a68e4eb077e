"""Typed errors of the service layer: each carries an HTTP-like status, the offending field and the reason.

The core raises ``romams_core.errors.InputError`` (a ValueError with ``field`` and ``reason``); the service
layer raises these. The API turns both into RFC 9457 problems with ``field`` (one handler, no parsing of
message text); the CLI turns them into a usage error naming the option; a worker stores them as the
structured error of the job (``as_dict``/``from_dict``), so the synchronous API path gets them back intact.
"""

from __future__ import annotations

from typing import Any

from romams_core.errors import InputError


class ServiceError(Exception):
    """A request that cannot be served: ``status`` (HTTP-like), ``field`` (dotted input name) and ``reason``."""

    status = 400

    def __init__(self, field: str | None, reason: str, *, extra: dict[str, Any] | None = None) -> None:
        self.field, self.reason, self.extra = field, reason, dict(extra or {})
        super().__init__(f"{field}: {reason}" if field else reason)

    @property
    def detail(self) -> str:
        """Human-readable '<field>: <reason>'."""
        return str(self)

    def as_dict(self) -> dict[str, Any]:
        """JSON form (stored with a failed job, returned through the result backend)."""
        return {"status": self.status, "field": self.field, "detail": self.detail, "reason": self.reason,
                **({"extra": self.extra} if self.extra else {})}

    @staticmethod
    def from_dict(d: dict[str, Any]) -> ServiceError:
        """Rebuild the typed error stored by :meth:`as_dict`."""
        cls = _BY_STATUS.get(int(d.get("status", 500)), ServerError)
        return cls(d.get("field"), str(d.get("reason", d.get("detail", "failed"))), extra=d.get("extra"))


class InvalidInput(ServiceError, ValueError):
    """422: a request field has a value the service cannot use."""

    status = 422


class NotFound(ServiceError):
    """404: a referenced resource does not exist."""

    status = 404


class Conflict(ServiceError):
    """409: the request is valid but the resource is not in a state that allows it (e.g. nothing trained)."""

    status = 409


class PayloadTooLarge(ServiceError):
    """413: an uploaded file is larger than the service takes."""

    status = 413


class ServerError(ServiceError):
    """500: the service failed on valid input."""

    status = 500


_BY_STATUS: dict[int, type[ServiceError]] = {422: InvalidInput, 404: NotFound, 409: Conflict, 413: PayloadTooLarge,
                                              500: ServerError}


#: Field roots the core uses for a whole input object: under a request ``prefix`` the prefix replaces them
#: (``design.x3`` under ``designs[2]`` is ``designs[2].x3``).
WHOLE_INPUT_ROOTS = ("design", "modes", "definition", "template", "wing", "file", "bdf", "json", "npz", "nastran")


def from_input_error(exc: InputError | ValueError, prefix: str | None = None) -> InvalidInput:
    """InvalidInput from a core InputError (its field nested under the request path ``prefix``) or a plain
    ValueError (reported under ``prefix`` as a whole)."""
    field = getattr(exc, "field", None)
    reason = getattr(exc, "reason", None) or str(exc)
    if prefix and field:
        root = field.split(".")[0].split("[")[0]
        if root in WHOLE_INPUT_ROOTS:
            field = prefix + field[len(root):]
        elif not field.startswith(prefix):
            field = f"{prefix}.{field}"
    return InvalidInput(field or prefix or None, reason)


def error_dict(exc: BaseException) -> dict[str, Any]:
    """Structured form of any exception raised while serving a request (typed when it is one of ours)."""
    if isinstance(exc, ServiceError):
        return exc.as_dict()
    if isinstance(exc, InputError | ValueError):
        return from_input_error(exc).as_dict()
    return ServerError(None, f"{type(exc).__name__}: {exc}").as_dict()
