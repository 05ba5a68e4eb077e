"""Server-rendered dashboard (/dashboard): jobs with live progress, wings, bases, ROMs, evaluations.

Plain HTML built with ``html.escape`` (no template engine, no third-party JS); api/static/dashboard.js
polls /api/v1/jobs every second and updates the job table in place. With API keys configured the page needs a read
key like every GET: without one it is a 401 page with no data but the key form, and the script fetches the page
again with the key (plots as ``data-src``, fetched with the key by the script). The batches of runs are left out:
a run is one row of the runs table, its page is api.dashboard_pages.
"""

from __future__ import annotations

import html
import json
from pathlib import Path
from typing import Any

from fastapi import APIRouter, Depends, Request
from fastapi.responses import HTMLResponse

from api.dashboard_pages import when
from api.deps import Service, key_problem, service

router = APIRouter(include_in_schema=False)
TEMPLATE = (Path(__file__).resolve().parent / "templates" / "dashboard.html").read_text()


def e(x: Any) -> str:
    """HTML-escaped text of a value."""
    return html.escape("" if x is None else str(x))


def _num(x: Any, fmt: str = ".4g") -> str:
    """Formatted number or an em dash."""
    return "&mdash;" if x is None else format(float(x), fmt)


def job_row(j: dict[str, Any]) -> str:
    """One row of the jobs table (the JS poller renders the same markup). No inline style (the Content-Security-
    Policy allows none): dashboard.js sizes each bar from its ``data-pct``."""
    pct = round(100 * float(j["progress"]))
    return (f'<tr data-job="{e(j["id"])}"><td><a class="mono" href="/dashboard/jobs/{e(j["id"])}">{e(j["id"][:8])}'
            f'</a></td><td>{e(j["kind"])}</td><td class="st st-{e(j["status"])}">{e(j["status"])}</td>'
            f'<td><div class="bar"><div class="fill" data-pct="{pct}"></div></div>'
            f'<span class="pct">{pct}%</span></td><td>{e(j["message"])}</td><td>{when(j["created_at"])}</td></tr>')


def _bases_html(svc: Service, wid: int) -> str:
    """Bases of a wing: size, worst MAC by number of shapes, per-sample MAC table, basis shapes image."""
    parts = []
    for b in svc.store.bases.of_wing(wid)[:3]:
        sm = b["summary"]
        by_m = sm.get("min_mac_by_m") or []
        head = "".join(f"<th>{i + 1}</th>" for i in range(len(by_m)))
        row = "".join(f'<td class="{"ok" if (v or 0) >= (sm.get("mac_threshold") or 0.98) else "bad"}">'
                      f"{_num(v, '.4f')}</td>" for v in by_m)
        table = sm.get("mac_table") or []
        k = int(sm.get("n_modes") or 1)
        samples = [table[i:i + k] for i in range(0, len(table), k)]
        mac_rows = "".join("<tr><td>" + str(i + 1) + "</td>" + "".join(f"<td>{_num(v, '.4f')}</td>" for v in s)
                           + "</tr>" for i, s in enumerate(samples))
        parts.append(
            f'<div class="basis"><h4>Basis {b["id"]}: m = {e(b["n_basis"])} shapes '
            f'(min MAC {_num(sm.get("min_mac"), ".4f")}, threshold {e(sm.get("mac_threshold"))}, '
            f'{e(b["params"].get("samples"))} samples &times; {e(b["params"].get("modes"))} modes)</h4>'
            f'<table class="mac"><tr><th>m</th>{head}</tr><tr><th>worst MAC</th>{row}</tr></table>'
            f'<details><summary>MAC of each sample mode with m shapes</summary><table class="mac">'
            f'<tr><th>sample</th>{"".join(f"<th>mode {i + 1}</th>" for i in range(k))}</tr>{mac_rows}</table>'
            f'</details><img class="shapes" alt="basis shapes" loading="lazy" '
            f'src="/api/v1/bases/{b["id"]}/shapes.png"></div>')
    return "".join(parts) or "<p>No basis yet.</p>"


def _roms_html(svc: Service, wid: int) -> str:
    """ROM table of a wing: Mach, solver, orders, validation error."""
    rows = []
    cp_plots = []
    for r in svc.store.roms.of_wing(wid):
        nrmse = r["summary"].get("validation_nrmse")
        worst = max(nrmse) if isinstance(nrmse, list) and nrmse else nrmse
        rows.append(f'<tr><td>{r["id"]}</td><td>{_num(r["mach"], ".3f")}</td><td>{e(r["solver"])}</td>'
                    f'<td>{e(r["params"].get("na"))}/{e(r["params"].get("nb"))}</td><td>{e(r["basis_id"])}</td>'
                    f'<td>{_num(worst, ".3%") if worst is not None else "&mdash;"}</td></tr>')
        if "mean_flow_converged" in r["summary"]:  # a TSD ROM: its transonic mean flow
            cp_plots.append(f'<figure><img class="meanflow" alt="TSD mean-flow Cp, ROM {r["id"]}" loading="lazy" '
                            f'src="/api/v1/roms/{r["id"]}/mean-flow.png"><figcaption>ROM {r["id"]}: mean-flow Cp, '
                            f'M {_num(r["mach"], ".3f")}</figcaption></figure>')
    if not rows:
        return "<p>No ROM trained yet.</p>"
    return ('<table><tr><th>ROM</th><th>Mach</th><th>solver</th><th>na/nb</th><th>basis</th>'
            f'<th>validation NRMSE (worst)</th></tr>{"".join(rows)}</table>'
            + (f'<details open><summary>Transonic mean flows (surface Cp)</summary>{"".join(cp_plots)}</details>'
               if cp_plots else ""))


def _evaluations_html(svc: Service) -> str:
    """Recent evaluations with their flutter points and V-g / envelope plots."""
    parts = []
    for ev in svc.store.evaluations.recent(limit=5):
        sm = ev["summary"]
        rows = "".join(f'<tr><td>{_num(r.get("mach"), ".3f")}</td><td>{_num(r.get("v_flutter_m_s"), ".1f")}</td>'
                       f'<td>{_num(r.get("omega_flutter_rad_s"), ".2f")}</td><td>{_num(r.get("q_flutter_pa"), ".0f")}'
                       f'</td><td>{e(r.get("flutter_mode"))}</td><td>{"yes" if r.get("sdoff") else "no"}</td>'
                       f'<td>{_num(r.get("safe_altitude_m"), ".0f")}</td></tr>' for r in sm.get("results", []))
        parts.append(
            f'<div class="eval"><h4>Evaluation {ev["id"]} (wing {ev["wing_id"]}, {e(ev["method"])}, '
            f'{e(ev["created_at"])}): mass {_num(sm.get("mass_kg"), ".4g")} kg, envelope ok: '
            f'{e(sm.get("envelope_ok"))}</h4><table><tr><th>Mach</th><th>V_f (m/s)</th><th>&omega;_f (rad/s)</th>'
            f'<th>q_f (Pa)</th><th>mode</th><th>SDOFF</th><th>safe altitude (m)</th></tr>{rows}</table>'
            + "".join(f'<img class="vg" alt="V-g and V-f at Mach {r.get("mach")}" loading="lazy" '
                      f'src="/api/v1/evaluations/{ev["id"]}/plot.png?kind=vg&amp;mach={r.get("mach")}">'
                      for r in sm.get("results", []))
            + f'<img alt="envelope" loading="lazy" src="/api/v1/evaluations/{ev["id"]}/plot.png?kind=envelope"></div>')
    return "".join(parts) or "<p>No evaluation yet.</p>"


def _page(jobs: str, wings: str, evaluations: str, config: dict[str, Any]) -> str:
    """The template filled in."""
    return (TEMPLATE.replace("{{jobs}}", jobs).replace("{{wings}}", wings).replace("{{evaluations}}", evaluations)
            .replace("{{config}}", html.escape(json.dumps(config))))


@router.get("/dashboard", response_class=HTMLResponse)
def dashboard(request: Request, svc: Service = Depends(service)) -> HTMLResponse:
    """The dashboard page (with keys configured: for a read key; without one a 401 page asking for it)."""
    keys = svc.settings.api_keys
    problem = key_problem(keys, request.headers.get("authorization", ""), "read") if keys else None
    if problem is not None:  # 401 without a key, 403 with a wrong one: the page without data, asking for one
        return HTMLResponse(_page("", "<p>An API key with the read scope is needed.</p>", "",
                                  {"auth": True, "authorized": False}), status_code=problem.status,
                            headers={**(problem.headers or {}), "Cache-Control": "no-store"})
    jobs = svc.store.jobs.recent(limit=30, top_level=True, include_runs=False)
    wings = []
    for w in svc.store.wings.all():
        wings.append(f'<section class="wing" data-wing="{w["id"]}"><h3>Wing {w["id"]}: {e(w["name"])}</h3>'
                     f'<h4>Bases</h4>{_bases_html(svc, w["id"])}<h4>ROMs</h4>{_roms_html(svc, w["id"])}</section>')
    wings_html, evals_html = "".join(wings) or "<p>No wing yet.</p>", _evaluations_html(svc)
    if keys:  # an <img> cannot send the key: the script fetches these with it
        wings_html, evals_html = (x.replace(' src="/api/', ' data-src="/api/') for x in (wings_html, evals_html))
    page = _page("".join(job_row(j) for j in jobs), wings_html, evals_html, {"auth": bool(keys), "authorized": True})
    return HTMLResponse(page, headers={"Cache-Control": "no-store"} if keys else None)
