"""Dashboard pages of runs and jobs: run list, run page (live plots), job list (filters, pages) and job detail.

The run and job-list pages are drawn by their scripts (api/static/run.js, jobs.js) from the JSON API; the job detail
is rendered here (parameters, progress history, error and traceback, timings, worker) and kept live by job.js.
Everything is served from the package: no CDN, no inline script or style (the Content-Security-Policy allows none).
"""

from __future__ import annotations

import datetime as dt
import html
import json
from pathlib import Path
from typing import Any

from fastapi import APIRouter, Depends, Request
from fastapi.responses import HTMLResponse

from api.deps import Service, key_problem, service
from romams.persistence import FINAL

router = APIRouter(include_in_schema=False)
PAGE = (Path(__file__).resolve().parent / "templates" / "page.html").read_text()
PARAMS_SHOWN = 4000  # characters of a job's parameters shown (a batch carries its designs)


def e(x: Any) -> str:
    """HTML-escaped text of a value."""
    return html.escape("" if x is None else str(x))


def when(iso: str | None) -> str:
    """A timestamp: relative text filled in by common.js, the ISO time in the tooltip."""
    if not iso:
        return "&mdash;"
    return f'<time datetime="{e(iso)}" title="{e(iso)}" data-rel>{e(iso[:19].replace("T", " "))} UTC</time>'


def page(svc: Service, title: str, body: str, scripts: tuple[str, ...] = (), status: int = 200) -> HTMLResponse:
    """A dashboard page: the shared header and navigation, ``body`` and the page's scripts."""
    tags = "".join(f'<script src="/static/{s}"></script>' for s in scripts)
    out = (PAGE.replace("{{title}}", e(title)).replace("{{body}}", body).replace("{{scripts}}", tags)
           .replace("{{config}}", e(json.dumps({"auth": bool(svc.settings.api_keys), "authorized": True}))))
    return HTMLResponse(out, status_code=status)


def locked(request: Request, svc: Service, title: str) -> HTMLResponse | None:
    """With API keys configured and no read key on the request: the page without data (401/403), which common.js
    fetches again with the key kept in this tab; None when the request may see the page."""
    keys = svc.settings.api_keys
    problem = key_problem(keys, request.headers.get("authorization", ""), "read") if keys else None
    if problem is None:
        return None
    out = (PAGE.replace("{{title}}", e(title)).replace("{{scripts}}", "")
           .replace("{{body}}", '<p class="error">An API key with the read scope is needed.</p>')
           .replace("{{config}}", e(json.dumps({"auth": True, "authorized": False}))))
    return HTMLResponse(out, status_code=problem.status,
                        headers={**(problem.headers or {}), "Cache-Control": "no-store"})


def not_found(svc: Service, what: str) -> HTMLResponse:
    """A 404 page."""
    return page(svc, "not found", f'<h2>Not found</h2><p class="error">{e(what)}</p>', status=404)


@router.get("/dashboard/runs", response_class=HTMLResponse)
def runs_page(request: Request, svc: Service = Depends(service)) -> HTMLResponse:
    """All runs with their counts and best objective (live)."""
    if (shut := locked(request, svc, "runs")) is not None:
        return shut
    body = ('<section><h2>Runs <span id="poll-state" class="muted"></span></h2><table id="runs"><thead><tr>'
            "<th>run</th><th>name</th><th>wing</th><th>status</th><th>designs</th><th>feasible</th>"
            "<th>infeasible</th><th>best objective (kg)</th><th>created</th></tr></thead><tbody></tbody></table>"
            "</section>")
    return page(svc, "runs", body, ("runs.js",))


@router.get("/dashboard/runs/{run_id}", response_class=HTMLResponse)
def run_page(request: Request, run_id: int, svc: Service = Depends(service)) -> HTMLResponse:
    """One run: history, design variables, best design's envelope vs the benchmark, designs (live)."""
    if (shut := locked(request, svc, f"run {run_id}")) is not None:
        return shut
    run = svc.store.runs.get(run_id)
    if run is None:
        return not_found(svc, f"no run {run_id}")
    graded = run["settings"].get("penalty") == "graded"
    penalty = (f'mass + {e(run["settings"]["mu_kg"])} kg x (1 + envelope excess in km + MAC deficit / 0.02 + SDOFF '
               'Machs)' if graded else f'mass + {e(run["settings"]["mu_kg"])} kg')
    body = (f'<section id="run" data-run="{run["id"]}"><h2>Run {run["id"]}: {e(run["name"])} '
            f'<span id="run-status" class="badge"></span> <span id="poll-state" class="muted"></span></h2>'
            '<p id="run-counts" class="counts"></p>'
            f'<p class="muted">created {when(run["created_at"])}; objective = {penalty} '
            f'when infeasible (envelope above the benchmark by more than {e(run["settings"]["envelope_tol_m"])} m, '
            f'SDOFF, or a mode fitted with MAC &lt; {e(run["settings"]["mac_threshold"])}); '
            f'<a href="/dashboard/jobs?run_id={run["id"]}">batches of this run</a></p>'
            '<div class="plots"><figure><figcaption>Objective by evaluation and best so far</figcaption>'
            '<svg id="history" class="plot" viewBox="0 0 560 300" role="img" aria-label="objective history"></svg>'
            '</figure><figure><figcaption>Best design: safe altitude vs benchmark (lower passes)</figcaption>'
            '<svg id="envelope" class="plot" viewBox="0 0 560 300" role="img" aria-label="envelope"></svg></figure>'
            '<figure class="wide"><figcaption>Design variables (parallel coordinates, scaled to the bounds)'
            '</figcaption><svg id="parallel" class="plot" viewBox="0 0 1120 300" role="img" '
            'aria-label="design variables"></svg></figure></div>'
            '<h3>Designs <select id="design-order"><option value="new">newest first</option>'
            '<option value="best">best first</option></select></h3>'
            '<div class="scroll"><table id="designs"><thead></thead><tbody></tbody></table></div></section>')
    return page(svc, f"run {run['id']}", body, ("plots.js", "run.js"))


@router.get("/dashboard/jobs", response_class=HTMLResponse)
def jobs_page(request: Request, svc: Service = Depends(service)) -> HTMLResponse:
    """Jobs with filters (status, kind, wing, run) and pages; batches of runs only when filtered by run."""
    if (shut := locked(request, svc, "jobs")) is not None:
        return shut
    status = "".join(f'<option value="{s}">{s}</option>' for s in ("queued", "running", "succeeded", "failed",
                                                                   "cancelled"))
    body = ('<section><h2>Jobs <span id="poll-state" class="muted"></span></h2><form id="job-filters" '
            'class="filters"><label>status <select name="status"><option value="">any</option>'
            f'{status}</select></label> <label>kind <input name="kind" size="14"></label> '
            '<label>wing <input name="wing_id" size="5" inputmode="numeric"></label> '
            '<label>run <input name="run_id" size="5" inputmode="numeric"></label> '
            '<label><input type="checkbox" name="include_children"> chunks</label></form>'
            '<table id="jobs"><thead><tr><th>job</th><th>kind</th><th>status</th><th>progress</th><th>message</th>'
            '<th>wing</th><th>run</th><th>created</th><th></th></tr></thead><tbody></tbody></table>'
            '<p class="pager"><button type="button" id="prev">&larr; newer</button> <span id="page-info"></span> '
            '<button type="button" id="next">older &rarr;</button></p></section>')
    return page(svc, "jobs", body, ("jobs.js",))


def _duration(a: str | None, b: str | None) -> str:
    """Seconds between two ISO timestamps ("&mdash;" when one is missing)."""
    if not a or not b:
        return "&mdash;"
    s = (dt.datetime.fromisoformat(b.replace("Z", "+00:00")) - dt.datetime.fromisoformat(a.replace("Z", "+00:00")))
    return f"{s.total_seconds():.3g} s"


def _params_text(params: dict[str, Any]) -> str:
    """A job's parameters as indented JSON, long design lists cut short."""
    text = json.dumps(params, indent=1, default=str)
    return text if len(text) <= PARAMS_SHOWN else text[:PARAMS_SHOWN] + f"\n... ({len(text)} characters in all)"


def _job_sections(svc: Service, job: dict[str, Any]) -> str:
    """Timings, error, progress history, children and parameters of a job."""
    error = ""
    if job["error"] or job["traceback"]:
        error = (f'<section id="job-error"><h3>Error</h3><pre class="error">{e(job["error"])}</pre>'
                 + (f'<details open><summary>Traceback</summary><pre class="traceback">{e(job["traceback"])}</pre>'
                    "</details>" if job["traceback"] else "") + "</section>")
    events = "".join(f"<tr><td>{when(t)}</td><td>{100 * float(p):.0f}%</td><td>{e(m)}</td></tr>"
                     for t, p, m in job["events"])
    kids = svc.store.jobs.children(job["id"])
    kid_rows = "".join(f'<tr><td><a class="mono" href="/dashboard/jobs/{e(k["id"])}">{e(k["id"][:8])}</a></td>'
                       f'<td>{e(k["kind"])}</td><td class="st st-{e(k["status"])}">{e(k["status"])}</td>'
                       f'<td>{_duration(k["started_at"], k["finished_at"])}</td><td>{e(k["worker"])}</td></tr>'
                       for k in kids[:200])
    return (error
            + '<section><h3>Timings</h3><table class="kv">'
            f'<tr><th>created</th><td>{when(job["created_at"])}</td></tr>'
            f'<tr><th>started</th><td>{when(job["started_at"])}</td></tr>'
            f'<tr><th>finished</th><td>{when(job["finished_at"])}</td></tr>'
            f'<tr><th>waited in the queue</th><td>{_duration(job["created_at"], job["started_at"])}</td></tr>'
            f'<tr><th>ran</th><td>{_duration(job["started_at"], job["finished_at"])}</td></tr>'
            f'<tr><th>worker</th><td class="mono">{e(job["worker"]) or "&mdash;"}</td></tr>'
            f'<tr><th>deliveries</th><td>{e(job["deliveries"])}</td></tr></table></section>'
            + (f'<section><h3>Progress history</h3><table id="events"><tr><th>time</th><th>progress</th>'
               f'<th>message</th></tr>{events}</table></section>' if events else "")
            + (f'<section><h3>Chunks ({len(kids)})</h3><table><tr><th>job</th><th>kind</th><th>status</th>'
               f'<th>ran</th><th>worker</th></tr>{kid_rows}</table></section>' if kids else "")
            + f'<section><h3>Parameters</h3><pre id="params">{e(_params_text(job["params"]))}</pre></section>')


@router.get("/dashboard/jobs/{job_id}", response_class=HTMLResponse)
def job_page(request: Request, job_id: str, svc: Service = Depends(service)) -> HTMLResponse:
    """One job: status and progress (live), parameters, progress history, error with traceback, timings, worker."""
    if (shut := locked(request, svc, f"job {job_id[:8]}")) is not None:
        return shut
    job = svc.store.jobs.get(job_id) if len(job_id) <= 64 and "\x00" not in job_id else None
    if job is None:
        return not_found(svc, f"no job {job_id!r}")
    pct = round(100 * float(job["progress"]))
    links = []
    if job["parent_id"]:
        links.append(f'part of <a href="/dashboard/jobs/{e(job["parent_id"])}">{e(job["parent_id"][:8])}</a>')
    if job["run_id"] is not None:
        links.append(f'run <a href="/dashboard/runs/{job["run_id"]}">{job["run_id"]}</a>')
    if job["wing_id"] is not None:
        links.append(f'wing {job["wing_id"]}')
    cancel = ('<button type="button" id="cancel" class="cancel">cancel</button>'
              if job["status"] not in FINAL else "")
    body = (f'<section id="job" data-job="{e(job["id"])}" data-status="{e(job["status"])}">'
            f'<h2>Job <span class="mono">{e(job["id"])}</span></h2>'
            f'<p>{e(job["kind"])} &middot; <span id="job-status" class="st st-{e(job["status"])}">'
            f'{e(job["status"])}</span> &middot; <span class="bar"><span class="fill" data-pct="{pct}"></span></span>'
            f'<span id="job-pct" class="pct">{pct}%</span> <span id="job-message">{e(job["message"])}</span> '
            f'{cancel}</p><p class="muted">{" &middot; ".join(links)}</p>'
            f'{_job_sections(svc, job)}</section>')
    return page(svc, f"job {job['id'][:8]}", body, ("job.js",))
