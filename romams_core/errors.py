"""Typed errors of the numerical core.

Every input check of ``romams_core`` raises :class:`InputError`: a ``ValueError`` (so callers that catch
ValueError keep working) that names the offending input. ``field`` is the dotted name of that input as the
caller passed it (``"mach"``, ``"aero.A"``, ``"design.x3"``, ``"planform.root_chord"``), ``reason`` says what
is wrong with it, and ``str(exc)`` is ``"<field>: <reason>"``. The service layer maps ``field`` to the request
field of an HTTP problem without parsing message text.
"""

from __future__ import annotations

__all__ = ["InputError"]


class InputError(ValueError):
    """An input of a core function is invalid: ``field`` (dotted input name) and ``reason``."""

    def __init__(self, field: str, reason: str) -> None:
        self.field = str(field)
        self.reason = str(reason)
        super().__init__(f"{self.field}: {self.reason}")

    def __reduce__(self) -> tuple[type[InputError], tuple[str, str]]:
        """Pickle support (worker processes send errors back): rebuild from (field, reason)."""
        return (type(self), (self.field, self.reason))

    def under(self, prefix: str) -> InputError:
        """The same error with ``field`` nested under ``prefix`` (``"x3"`` -> ``"design.x3"``)."""
        return type(self)(f"{prefix}.{self.field}" if self.field else prefix, self.reason)
