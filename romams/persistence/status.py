"""The states of a job row and the two groups the guarded transitions use."""

from __future__ import annotations

from enum import StrEnum


class JobStatus(StrEnum):
    """Status of a job; a ``str`` subclass, so it compares equal to and serializes as the plain text."""

    QUEUED = "queued"
    RUNNING = "running"
    SUCCEEDED = "succeeded"
    FAILED = "failed"
    CANCELLED = "cancelled"

    @property
    def is_final(self) -> bool:
        """True for succeeded, failed and cancelled (no transition leaves these)."""
        return self in FINAL


#: states a job can still leave (a worker may run it)
ACTIVE: frozenset[JobStatus] = frozenset({JobStatus.QUEUED, JobStatus.RUNNING})
#: states no transition leaves
FINAL: frozenset[JobStatus] = frozenset({JobStatus.SUCCEEDED, JobStatus.FAILED, JobStatus.CANCELLED})


def values(statuses: frozenset[JobStatus] | tuple[JobStatus | str, ...] | list[JobStatus | str]) -> tuple[str, ...]:
    """Plain, sorted text values of ``statuses`` (what is written to and compared in the database)."""
    return tuple(sorted(JobStatus(s).value for s in statuses))
