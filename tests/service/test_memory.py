"""The API process hands freed heap memory back to the kernel (romams.memory, docs/reliability.md)."""

from __future__ import annotations

import threading
import time
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from api.app import create_app
from romams.memory import _glibc, heap_trimmer, limit_malloc_arenas, trim_heap
from romams.settings import Settings

pytestmark = pytest.mark.skipif(_glibc() is None, reason="malloc_trim and mallopt are glibc's")
CHUNK, COUNT = 1024, 60_000  # 60 MiB in chunks glibc serves from its heap (below the mmap threshold)


def rss_mib() -> float:
    """Resident set size of this process, MiB."""
    with open("/proc/self/status") as f:
        line = next(x for x in f if x.startswith("VmRSS:"))
    return int(line.split()[1]) / 1024


def fragmented_free_memory() -> tuple[list[bytes], float]:
    """Allocate COUNT chunks, free all but one allocated after them: the free run cannot shrink the heap's top.
    Returns (the live chunk, RSS in MiB while all chunks were live: a trimmer thread may release the run as soon
    as it is freed, so the level to compare with is read before)."""
    chunks = [bytes(CHUNK) for _ in range(COUNT)]
    keep = [bytes(CHUNK)]  # allocated last: pins the top of the heap
    full = rss_mib()
    for i in range(COUNT):
        chunks[i] = b""
    del chunks
    return keep, full


def test_trim_hands_a_freed_run_of_heap_back_to_the_kernel() -> None:
    """60 MiB freed below a live chunk stay resident until trim_heap; then at least 30 MiB are released."""
    keep, full = fragmented_free_memory()
    before = rss_mib()
    assert before > full - 10.0, (full, before)  # freed, still resident: nothing trims in this test
    assert trim_heap()
    after = rss_mib()
    assert before - after >= 30.0, (before, after)
    assert keep


def test_the_trimmer_thread_trims_periodically_and_stops() -> None:
    """heap_trimmer releases the same run on its own within a second and its thread ends on stop()."""
    trimmer = heap_trimmer(0.05).start()
    try:
        keep, peak = fragmented_free_memory()  # peak read before the free: the trimmer may act at once
        deadline = time.monotonic() + 5.0
        while rss_mib() > peak - 30.0 and time.monotonic() < deadline:
            time.sleep(0.05)
        assert rss_mib() <= peak - 30.0
        assert keep
    finally:
        trimmer.stop(join_s=5.0)
    assert not any(t.name == "romams-heap-trim" for t in threading.enumerate())


def test_arena_limit_is_applied_only_for_a_positive_count() -> None:
    assert limit_malloc_arenas(0) is False
    assert limit_malloc_arenas(8) is True


def test_the_api_runs_its_trimmer_while_it_serves(tmp_path: Path) -> None:
    """create_app's lifespan starts the trimmer (heap_trim_s > 0) and stops it at shutdown; 0 turns it off."""
    def trimmers() -> int:
        return sum(t.name == "romams-heap-trim" for t in threading.enumerate())

    with TestClient(create_app(Settings(data_dir=tmp_path / "a", heap_trim_s=0.05), sweeper=False)) as c:
        assert c.get("/api/v1/health").status_code == 200
        assert trimmers() == 1
    assert trimmers() == 0
    with TestClient(create_app(Settings(data_dir=tmp_path / "b", heap_trim_s=0), sweeper=False)):
        assert trimmers() == 0
