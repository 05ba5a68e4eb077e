"""Exceptions of the romams client: the server's RFC 9457 problem details as Python exceptions."""

from __future__ import annotations

from typing import Any


class RomamsError(Exception):
    """An error answered by the service (problem+json), or a failed / cancelled job.

    ``status`` is the HTTP status (0 when no response was received), ``title`` / ``detail`` / ``field``
    come from the problem body (``field`` names the offending request field, dotted), ``body`` is the
    whole problem object.
    """

    def __init__(self, status: int, title: str, detail: str, field: str | None = None,
                 body: dict[str, Any] | None = None) -> None:
        self.status = int(status)
        self.title = title
        self.detail = detail
        self.field = field
        self.body = dict(body or {})
        super().__init__(f"{status} {title}: {detail}" if status else f"{title}: {detail}")

    @property
    def errors(self) -> list[dict[str, Any]]:
        """All validation errors of the request (``[{"field", "reason"}]``), when the server listed them."""
        errs = self.body.get("errors")
        return list(errs) if isinstance(errs, list) else []

    @classmethod
    def from_response(cls, status: int, body: Any, text: str = "") -> RomamsError:
        """Error from a non-2xx response: its problem JSON when there is one, else the raw text."""
        if isinstance(body, dict) and ("detail" in body or "title" in body):
            detail = body.get("detail")
            if not isinstance(detail, str):  # FastAPI's default {"detail": [...]} shape
                detail = str(detail)
            return cls(status, str(body.get("title") or "Error"), detail, body.get("field"), body)
        return cls(status, "Error", (text or "").strip()[:500] or "no detail", None,
                   body if isinstance(body, dict) else None)


class JobError(RomamsError):
    """A job ended failed or cancelled (``job`` holds the job as the service reported it)."""

    def __init__(self, job: dict[str, Any]) -> None:
        self.job = dict(job)
        status = str(job.get("status"))
        detail = (job.get("error") or job.get("message") or status).strip().splitlines()[0] if status else "?"
        super().__init__(0, f"job {job.get('id')} ({job.get('kind')}) {status}", detail, None, job)


class JobTimeout(RomamsError):
    """A job did not end within the caller's timeout (it may still be running on the service)."""

    def __init__(self, job: dict[str, Any], timeout_s: float) -> None:
        self.job = dict(job)
        super().__init__(0, f"job {job.get('id')} timed out",
                         f"still {job.get('status')} after {timeout_s:g} s (progress {job.get('progress')})",
                         None, job)
