"""Database errors as the rest of the service sees them (nothing outside this package imports SQLAlchemy).

A unit of work turns SQLAlchemy's errors into two types: :class:`DatabaseUnavailable` when the database cannot be
reached or answer (connection refused or dropped, server shutting down, pool exhausted, SQLite file unreadable),
which the API answers with 503 and ``Retry-After``; and :class:`InvalidValue` when it refuses a value (integer
out of range, NUL character, text too long), an input error (422). Everything else passes unchanged.
"""

from __future__ import annotations

from sqlalchemy import exc as sa_exc

from romams_core.errors import InputError

#: Largest id of a row: the id columns are ``Integer``, 32-bit on PostgreSQL (64-bit on SQLite); a larger id
#: cannot name a row, and PostgreSQL refuses it as a parameter.
ID_MAX = 2**31 - 1
ID_MIN = -(2**31)


def id_in_range(value: object) -> bool:
    """True when ``value`` is an int the id columns can hold (so it can be looked up)."""
    try:
        return ID_MIN <= int(value) <= ID_MAX  # type: ignore[call-overload]
    except (TypeError, ValueError, OverflowError):
        return False


class DatabaseUnavailable(RuntimeError):
    """The database cannot be reached or did not answer; the request may be retried later."""


class InvalidValue(InputError):
    """The database refused a value of the request (out of range, NUL character, too long)."""

    def __init__(self, field: str = "value", reason: str = "the database refused a value") -> None:
        super().__init__(field, reason)


def translate(exc: BaseException) -> Exception | None:
    """The service's exception for a database error (None when ``exc`` is not one to translate)."""
    if isinstance(exc, (sa_exc.OperationalError, sa_exc.InterfaceError, sa_exc.DisconnectionError,
                        sa_exc.TimeoutError)) or (isinstance(exc, sa_exc.DBAPIError) and exc.connection_invalidated):
        orig = getattr(exc, "orig", None) or exc
        first = str(orig).strip().splitlines()[0] if str(orig).strip() else type(orig).__name__
        return DatabaseUnavailable(f"database: unavailable ({type(orig).__name__}: {first[:300]})")
    if isinstance(exc, sa_exc.DataError):
        orig = getattr(exc, "orig", None) or exc
        first = str(orig).strip().splitlines()[0] if str(orig).strip() else type(orig).__name__
        return InvalidValue("value", f"the database refused a value ({first[:300]})")
    if isinstance(exc, OverflowError) and "int" in str(exc).lower():  # sqlite3: an int beyond 64 bits
        return InvalidValue("value", f"an integer is out of the database's range ({exc})")
    return None
