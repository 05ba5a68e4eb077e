"""Dashboard load time with its plot images, first and second load, as a browser does it (JSON on stdout).

A small example in a temporary embedded service (SQLite, no worker): one cropped-delta wing and ``--evaluations``
stored evaluations of the typical section's flutter results at two Mach numbers (2 V-g plots + 1 envelope each).
A load is GET /dashboard plus every ``<img>`` on it; the second load sends the ETag of each image back in
If-None-Match, as a browser revalidating its cache does (a 304 costs no rendering); a third load without ETags
is another browser, answered from the server's plot cache. Usage:

    python -m benchmarks.dashboard_plots [--evaluations 3]
    python -m benchmarks.dashboard_plots --figures docs   # the example figures of docs/flutter.md section 8.1
"""

from __future__ import annotations

import argparse
import html
import json
import re
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

MACHS = (0.79, 0.87)
STIFFNESS = 3.0  # frequency factor that puts the section's flutter q inside the envelope's altitude range


def example_evaluation(scale: float = 1.0, benchmark: Any = None, stiffness: float = STIFFNESS) -> Any:
    """A StructureEvaluation of the typical section (frequencies x ``stiffness``, pitch frequency x ``scale``) at
    MACHS, compared with ``benchmark`` (an Envelope) when given."""
    from romams_core.envelope import compare_envelopes, envelope_from_results
    from romams_core.evaluate import StructureEvaluation
    from romams_core.flutter import flutter_analysis
    from romams_core.typical_section import TypicalSection, jones_discrete, modes

    ts = TypicalSection()
    w, _ = modes(ts)
    w = np.asarray(w, float) * stiffness * np.array([1.0, scale])
    aero = jones_discrete(ts, 0.05)
    results = [flutter_analysis(w, aero, ts.c_ref, m, zeta=0.01) for m in MACHS]
    env = envelope_from_results(results)
    comp = None if benchmark is None else compare_envelopes(env, benchmark)
    return StructureEvaluation(
        mass_kg=1.0, frequencies_hz=w / (2 * np.pi), mac=np.ones(w.size), min_mac=1.0, mac_ok=True,
        machs=np.array(MACHS), flutter=results, envelope=env, comparison=comp, sdoff=False,
        constraints_ok=comp is None or comp.envelope_ok, message="example")


def example_summary(wing_id: int, result: Any) -> dict[str, Any]:
    """The summary keys the dashboard reads of a stored evaluation."""
    rows = [{"mach": float(r.mach), "v_flutter_m_s": r.v_flutter_m_s, "omega_flutter_rad_s": r.omega_flutter_rad_s,
             "q_flutter_pa": r.q_flutter_pa, "flutter_mode": r.flutter_mode, "sdoff": r.sdoff,
             "safe_altitude_m": float(a)} for r, a in zip(result.flutter, result.envelope.safe_altitude_m,
                                                           strict=True)]
    ok = None if result.comparison is None else bool(result.comparison.envelope_ok)
    return {"wing_id": wing_id, "results": rows, "mass_kg": result.mass_kg, "envelope_ok": ok}


def _load(client: Any, etags: dict[str, str]) -> tuple[float, dict[str, int]]:
    """One dashboard load (page + images, If-None-Match from ``etags``): (seconds, status counts)."""
    t0 = time.perf_counter()
    page = client.get("/dashboard")
    counts: dict[str, int] = {}
    for src in re.findall(r'<img[^>]*src="([^"]+)"', page.text):
        url = html.unescape(src)
        headers = {"If-None-Match": etags[url]} if url in etags else {}
        r = client.get(url, headers=headers)
        counts[str(r.status_code)] = counts.get(str(r.status_code), 0) + 1
        if "etag" in r.headers:
            etags[url] = r.headers["etag"]
    return time.perf_counter() - t0, counts


def run(n_evaluations: int) -> dict[str, Any]:
    """First and second dashboard load of the example service (seconds and image status counts)."""
    from fastapi.testclient import TestClient

    from api.app import create_app
    from romams.settings import Settings

    with tempfile.TemporaryDirectory() as tmp:
        app = create_app(Settings(data_dir=Path(tmp)), sweeper=False)
        with TestClient(app) as client:
            wid = client.post("/api/v1/wings", json={"template": "cropped-delta", "name": "cd-plots"}).json()["id"]
            store = app.state.service.store
            base = example_evaluation(1.0)
            for i in range(n_evaluations):
                res = example_evaluation(1.0 + 0.05 * i, base.envelope)
                store.evaluations.save(wid, res, summary=example_summary(wid, res), request={"design": [i]})
            first, c1 = _load(client, etags := {})
            second, c2 = _load(client, etags)
            fresh, c3 = _load(client, {})  # another browser (no ETags): the server's cache answers
    return {"evaluations": n_evaluations, "first_load_s": round(first, 3), "second_load_s": round(second, 3),
            "other_browser_load_s": round(fresh, 3), "first_status": c1, "second_status": c2,
            "other_browser_status": c3}


def write_figures(directory: Path) -> list[str]:
    """The docs' example figures: V-g / V-f of the typical section at M 0.87 on the EAS axis, and the envelopes of
    a failing (pitch frequency x 0.9) and a passing design (x 1.1) against the baseline."""
    from romams.plots.flutter import envelope_figure, figure_bytes, vg_figure

    base = example_evaluation(1.0)
    soft, stiff = example_evaluation(0.9, base.envelope), example_evaluation(1.1, base.envelope)
    directory.mkdir(parents=True, exist_ok=True)
    envs = {"pitch frequency x 0.9": soft.envelope, "pitch frequency x 1.1": stiff.envelope}
    out = {"plots_vg.png": vg_figure(soft.flutter[1], axis="eas"),
           "plots_envelope.png": envelope_figure(envs, benchmark=base.envelope)}
    for name, fig in out.items():
        (directory / name).write_bytes(figure_bytes(fig, "png", dpi=72))
    return [str(directory / n) for n in out]


def main() -> None:
    """CLI entry point."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--evaluations", type=int, default=3)
    ap.add_argument("--figures", type=Path, default=None, help="write the docs' example figures here instead")
    args = ap.parse_args()
    if args.figures is not None:
        print(json.dumps(write_figures(args.figures)))
        return
    print(json.dumps(run(args.evaluations), indent=1))


if __name__ == "__main__":
    main()
