"""The run and job pages in a real headless Chromium against `romams serve`: a differential-evolution run started
through the client is drawn live (history, best design's envelope with the benchmark, design table); a failed job's
page shows its error and traceback; the job list leaves the run's batches out unless filtered by run.

``ROMAMS_DOCS_SCREENSHOTS=1`` also writes the screenshots of docs/service.md (docs/dashboard_run.png,
docs/dashboard_job.png), from a run over two Mach numbers.
"""

from __future__ import annotations

import importlib.util
import os
import threading
import time

import pytest
from fast_settings import DLM_FAST

from .browser import chromium_page
from .conftest import ROOT

pytestmark = pytest.mark.browser
SCREENSHOTS = os.environ.get("ROMAMS_DOCS_SCREENSHOTS") == "1"
POP, GENERATIONS = 6, 3
MACHS = [0.87, 0.95] if SCREENSHOTS else [0.87]  # the docs' screenshot: an envelope over two Machs
FAST_K = [0.0, 0.1, 0.3, 0.6, 1.0, 1.5]  # reduced frequencies of the ROM fit: fewer than the default, a quick ROM
PAUSE_S = 1.5  # between generations, so that the page (polling every second) sees the run go on


def _example():
    """examples/optimize_cropped_delta.py as a module (its DE driver: one batch request per generation)."""
    spec = importlib.util.spec_from_file_location("optimize_cropped_delta", ROOT / "examples/optimize_cropped_delta.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _shot(page, tmp, name: str) -> None:
    """Full-page screenshot into the test's directory (and docs/ with ROMAMS_DOCS_SCREENSHOTS=1)."""
    page.screenshot(path=str(tmp / name), full_page=True)
    if SCREENSHOTS:
        page.screenshot(path=str(ROOT / "docs" / name), full_page=True)


def _count(page, selector: str) -> int:
    """Number of elements matching ``selector``."""
    return int(page.eval_on_selector_all(selector, "els => els.length"))


def _wait_count(page, selector: str, n: int, timeout_s: float = 15.0) -> None:
    """Wait until ``n`` elements match ``selector`` (polled: the page's CSP forbids Playwright's string eval)."""
    deadline = time.monotonic() + timeout_s
    while _count(page, selector) != n:
        assert time.monotonic() < deadline, (selector, _count(page, selector), n)
        time.sleep(0.2)


def test_run_page_is_live_and_a_failed_job_shows_its_error(server):
    from client import FlutterProblem, RomamsClient

    base, tmp = server
    ex = _example()
    client = RomamsClient(base, timeout=120)
    wid = client.ensure_wing("cd-run-page", "cropped-delta")
    client.wait_job(client.start_basis(wid, samples=6, modes=3, seed=1), timeout_s=240, progress=False)
    client.train(wid, MACHS, options={"k_values": FAST_K, **DLM_FAST}, timeout_s=240, progress=False)
    problem = FlutterProblem(client, wid, machs=MACHS, mu=10.0, run="DE demo: cropped delta")
    evaluate = problem.evaluate

    def paced(x):  # a pause before each generation's batch: the run goes on while the page watches
        time.sleep(PAUSE_S)
        return evaluate(x)

    problem.evaluate = paced
    out: dict = {}
    de = threading.Thread(target=lambda: out.update(ex.run_de(problem, generations=GENERATIONS, popsize=POP, seed=2,
                                                              log=lambda m: None)))
    total = POP * (GENERATIONS + 1)
    with client, chromium_page(viewport={"width": 1280, "height": 1000}) as (browser, page, errors):
        page.goto(f"{base}/dashboard/runs/{problem.run_id}")
        page.wait_for_selector("#history .empty")  # nothing evaluated yet
        de.start()
        seen: dict[int, int] = {}  # designs shown -> history points drawn
        deadline = time.monotonic() + 240
        while time.monotonic() < deadline:
            n = int(page.text_content("#n-evaluations") or 0)
            seen[n] = _count(page, "#history .data circle")
            if n == total:
                break
            time.sleep(0.25)
        de.join(timeout=60)
        assert out.get("nfev") == total, out
        # it updated while the run went on: intermediate generations were drawn, not only the end
        assert sorted(seen)[-1] == total and len([n for n in seen if 0 < n < total]) >= 2, seen
        _wait_count(page, "#history .data circle", total)
        drawn = [seen[n] for n in sorted(seen)]  # the history plot grew with the count of designs
        assert drawn == sorted(drawn) and any(0 < d < total for d in drawn), seen
        assert _count(page, "#designs tbody tr") == total
        assert _count(page, "#parallel .lines path") == total
        run = client.get_run(problem.run_id)
        assert run["n_evaluations"] == total and run["n_feasible"] + run["n_infeasible"] == total
        assert page.text_content("#n-feasible") == str(run["n_feasible"])
        if run["n_feasible"]:
            assert _count(page, "#history .best-so-far") == 1
        # the best design's envelope against the benchmark, shaded by pass / fail
        assert _count(page, "#envelope path.benchmark") == 1 and _count(page, "#envelope path.best-design") == 1
        assert _count(page, "#envelope .pass, #envelope .fail") >= 1
        page.select_option("#design-order", "best")  # the table sorted best first: the run's best on top
        assert page.get_attribute("#designs tbody tr:first-child", "data-eval") == str(run["best"]["id"])
        assert page.get_attribute("#designs tbody tr:first-child", "class") == "best"
        _shot(page, tmp, "dashboard_run.png")

        # a failed job: its page shows the error and the traceback
        job_id = client.start_training(wid, 0.5, solver="uvlm", options={"k_max": -1.0})[0]["job_id"]
        deadline = time.monotonic() + 120
        while client.get_job(job_id)["status"] not in ("failed", "succeeded", "cancelled"):
            assert time.monotonic() < deadline
            time.sleep(0.3)
        page.goto(f"{base}/dashboard/jobs/{job_id}")
        assert page.text_content("#job-status") == "failed"
        assert "k_max" in page.text_content("#job-error pre.error")
        assert "Traceback (most recent call last)" in page.text_content("#job-error pre.traceback")
        assert page.get_attribute("#job-error time, table.kv time", "title") is not None
        _shot(page, tmp, "dashboard_job.png")

        # the job list: the run's batches only when filtered by run; relative times with the ISO time as title
        page.goto(f"{base}/dashboard/jobs")
        page.wait_for_selector(f'#jobs tr[data-job="{job_id}"]')
        assert "ago" in page.text_content(f'#jobs tr[data-job="{job_id}"] time')
        assert _count(page, "#jobs td a[href^='/dashboard/runs/']") == 0
        page.goto(f"{base}/dashboard/jobs?run_id={problem.run_id}")
        _wait_count(page, f'#jobs tbody a[href="/dashboard/runs/{problem.run_id}"]', GENERATIONS + 1)
        assert not errors, errors
