// Run page: polls the run's summary every second and fetches only the evaluations it has not seen (after_id), then
// redraws the objective history with the best so far, the best design's envelope against the benchmark, the design
// variables as parallel coordinates, and the table of designs.
"use strict";
(function () {
  const R = window.romams, P = window.svgplot;
  const runId = document.getElementById("run").dataset.run;
  const state = document.getElementById("poll-state");
  const order = document.getElementById("design-order");
  const GREEN = "#2a9d8f", RED = "#d1495b", GREY = "#b8c0c8", DARK = "#1d3557", ROWS = 50;
  let evals = [], lastId = 0, summary = null, wing = null;

  function num(x, d) { return x === null || x === undefined ? "&mdash;" : Number(x).toPrecision(d || 4); }

  function drawHistory() {
    const svg = document.getElementById("history");
    const pts = evals.map(function (e, i) { return [i + 1, e.objective, e.feasible]; }).filter(function (p) { return p[1] !== null; });
    if (!pts.length) { P.message(svg, "waiting for the first evaluations..."); return; }
    const feas = pts.filter(function (p) { return p[2]; });
    const all = pts.map(function (p) { return p[1]; });
    const lo = Math.min.apply(null, all);
    const fmax = feas.length ? Math.max.apply(null, feas.map(function (p) { return p[1]; })) : Math.max.apply(null, all);
    const top = feas.length ? fmax + 0.25 * ((fmax - lo) || Math.abs(fmax) || 1) : fmax;
    const f = P.frame(svg, { xmin: 1, xmax: Math.max(2, pts[pts.length - 1][0]), ymin: lo, ymax: top,
                             xlabel: "evaluation", ylabel: "objective (kg)" });
    const clip = function (p) { return [p[0], Math.min(p[1], top)]; };
    P.dots(f, pts.filter(function (p) { return !p[2]; }).map(clip), { fill: "none", stroke: RED, class: "infeasible" }, 2.5);
    P.dots(f, feas, { fill: GREEN, class: "feasible" }, 2.5);
    let best = Infinity;
    const steps = [];
    for (const p of pts) {
      if (p[2] && p[1] < best) { if (steps.length) steps.push([p[0], best]); best = p[1]; steps.push([p[0], best]); }
    }
    if (steps.length) steps.push([pts[pts.length - 1][0], best]);
    P.line(f, steps, { stroke: DARK, class: "best-so-far" });
    P.legend(f, [{ label: "feasible", color: GREEN, dot: true }, { label: "infeasible (mass + \u03bc)", color: RED, dot: true },
                 { label: "best feasible so far", color: DARK }]);
  }

  function drawEnvelope() {
    const svg = document.getElementById("envelope");
    const best = summary && summary.best;
    const rows = best ? best.flutter.filter(function (r) { return r[4] !== null && r[5] !== null; }) : [];
    if (!rows.length) { P.message(svg, best ? "the best design has no safe altitude to compare" : "no design yet"); return; }
    const machs = rows.map(function (r) { return r[0]; });
    const alts = rows.map(function (r) { return r[4]; }).concat(rows.map(function (r) { return r[5]; }));
    const f = P.frame(svg, { xmin: Math.min.apply(null, machs) - 0.02, xmax: Math.max.apply(null, machs) + 0.02,
                             ymin: Math.min.apply(null, alts), ymax: Math.max.apply(null, alts), xlabel: "Mach",
                             ylabel: "safe altitude (m)", xticks: machs });
    const tol = Number(summary.settings.envelope_tol_m);
    const pass = function (r) { return r[4] <= r[5] + tol; };
    for (let i = 0; i + 1 < rows.length; i++) {
      const a = rows[i], b = rows[i + 1];
      P.area(f, [[a[0], a[4]], [b[0], b[4]]], [[a[0], a[5]], [b[0], b[5]]],
             { fill: pass(a) && pass(b) ? GREEN : RED, "fill-opacity": 0.18, class: pass(a) && pass(b) ? "pass" : "fail" });
    }
    for (const r of rows) {
      P.el(f.root, "line", { x1: f.x(r[0]), x2: f.x(r[0]), y1: f.y(r[4]), y2: f.y(r[5]), stroke: pass(r) ? GREEN : RED,
                             "stroke-width": 6, "stroke-opacity": 0.35, class: pass(r) ? "pass" : "fail" });
    }
    P.line(f, rows.map(function (r) { return [r[0], r[5]]; }), { stroke: "#333", "stroke-dasharray": "6 4", class: "benchmark" });
    P.dots(f, rows.map(function (r) { return [r[0], r[5]]; }), { fill: "#333", class: "benchmark-points" }, 3);
    P.line(f, rows.map(function (r) { return [r[0], r[4]]; }), { stroke: DARK, class: "best-design" });
    P.dots(f, rows.map(function (r) { return [r[0], r[4]]; }), { fill: DARK }, 3.5);
    P.legend(f, [{ label: "best design #" + best.id, color: DARK }, { label: "benchmark", color: "#333", dash: "6 4" },
                 { label: "passes", color: GREEN, dot: true }, { label: "fails", color: RED, dot: true }]);
  }

  function drawParallel() {
    const svg = document.getElementById("parallel");
    const dvs = (wing && wing.design_variables) || [];
    if (!dvs.length || !evals.length) { P.message(svg, "no design yet"); return; }
    while (svg.firstChild) svg.removeChild(svg.firstChild);
    const W = 1120, H = 300, L = 50, Rr = 50, T = 20, B = 40, n = dvs.length;
    const x = function (i) { return L + i * (W - L - Rr) / Math.max(1, n - 1); };
    const y = function (u) { return H - B - Math.min(1, Math.max(0, u)) * (H - T - B); };
    const u = function (e, i) { return (e.x[i] - dvs[i].lower) / ((dvs[i].upper - dvs[i].lower) || 1); };
    const g = P.el(svg, "g", { class: "lines", fill: "none" });
    const shown = evals.slice(-1000);
    for (const e of shown) {
      if (e.x.length !== n) continue;
      const d = e.x.map(function (_, i) { return (i ? "L" : "M") + x(i).toFixed(1) + " " + y(u(e, i)).toFixed(1); }).join(" ");
      P.el(g, "path", { d: d, stroke: e.feasible ? GREEN : GREY, "stroke-opacity": e.feasible ? 0.5 : 0.35 });
    }
    const best = summary && summary.best;
    if (best && best.x.length === n) {
      const d = best.x.map(function (_, i) { return (i ? "L" : "M") + x(i).toFixed(1) + " " + y(u(best, i)).toFixed(1); }).join(" ");
      P.el(svg, "path", { d: d, stroke: DARK, "stroke-width": 3, fill: "none", class: "best-design" });
    }
    dvs.forEach(function (v, i) {
      P.el(svg, "line", { x1: x(i), x2: x(i), y1: T, y2: H - B, stroke: "#555" });
      P.el(svg, "text", { x: x(i), y: H - B + 16, "text-anchor": "middle", "font-size": 12 }, v.name);
      P.el(svg, "text", { x: x(i), y: H - 8, "text-anchor": "middle", "font-size": 10, fill: "#778" },
           P.fmt(v.lower) + " \u2013 " + P.fmt(v.upper) + (v.unit ? " " + v.unit : ""));
    });
  }

  function drawTable() {
    const table = document.getElementById("designs");
    const dvs = (wing && wing.design_variables) || [];
    const nx = dvs.length || (evals[0] ? evals[0].x.length : 0);
    const machs = evals.length ? evals[evals.length - 1].flutter.map(function (r) { return r[0]; }) : [];
    let head = "<tr><th>#</th><th>batch</th>";
    for (let i = 0; i < nx; i++) head += "<th>" + R.esc(dvs[i] ? dvs[i].name : "x" + (i + 1)) + "</th>";
    head += "<th>mass (kg)</th><th>objective (kg)</th><th>feasible</th><th>envelope ok</th><th>min MAC</th>";
    for (const m of machs) {
      head += "<th>M " + m + ": V<sub>EAS,f</sub> (m/s)</th><th>f<sub>f</sub> (Hz)</th><th>safe alt. (m)</th>";
    }
    head += "<th>V-g</th></tr>";
    table.tHead.innerHTML = head;
    const index = new Map(evals.map(function (e, i) { return [e.id, i + 1]; }));
    let rows = evals.slice();
    if (order.value === "best") {
      rows.sort(function (a, b) {
        return (b.feasible - a.feasible) || ((a.objective === null) - (b.objective === null)) || (a.objective - b.objective);
      });
    } else rows.reverse();
    const bestId = summary && summary.best ? summary.best.id : null;
    table.tBodies[0].innerHTML = rows.slice(0, ROWS).map(function (e) {
      let h = '<tr data-eval="' + e.id + '"' + (e.id === bestId ? ' class="best"' : "") + "><td>" + index.get(e.id) +
        "</td><td>" + (e.job_id ? '<a class="mono" href="/dashboard/jobs/' + R.esc(e.job_id) + '">' + R.esc(e.job_id.slice(0, 8)) + "</a>" : "") + "</td>";
      for (let i = 0; i < nx; i++) h += "<td>" + num(e.x[i]) + "</td>";
      h += "<td>" + num(e.mass_kg) + "</td><td>" + num(e.objective) + '</td><td class="' + (e.feasible ? "ok" : "bad") + '">' +
        (e.error ? R.esc(e.error) : e.feasible ? "yes" : "no") + "</td><td>" + (e.envelope_ok === null ? "&mdash;" : e.envelope_ok ? "yes" : "no") +
        "</td><td>" + num(e.min_mac, 6) + "</td>";
      for (let k = 0; k < machs.length; k++) {
        const r = e.flutter[k] || [];
        h += "<td>" + num(r[1]) + "</td><td>" + num(r[2]) + "</td><td>" + num(r[4], 5) + "</td>";
      }
      h += "<td>" + (e.evaluation_id ? '<a href="/api/v1/evaluations/' + e.evaluation_id + '/plot.png?kind=vg">plot</a>' : "") + "</td></tr>";
      return h;
    }).join("");
  }

  function drawSummary() {
    const s = summary;
    const badge = document.getElementById("run-status");
    badge.textContent = s.status;
    badge.className = "badge st-" + s.status;
    const best = s.best;
    document.getElementById("run-counts").innerHTML =
      '<b id="n-evaluations">' + s.n_evaluations + '</b> designs: <b class="ok" id="n-feasible">' + s.n_feasible +
      '</b> feasible, <b class="bad" id="n-infeasible">' + s.n_infeasible + "</b> infeasible, " + s.n_failed + " failed" +
      (best ? " &middot; best objective <b>" + num(best.objective) + " kg</b> (mass " + num(best.mass_kg) + " kg, " +
              (best.feasible ? "feasible" : "infeasible") + ")" : "") +
      " &middot; " + (s.bytes_per_design === null ? "" : Math.round(s.bytes_per_design) + " bytes per design stored, ") +
      "V-g data kept for " + s.n_with_vg;
  }

  async function poll() {
    try {
      summary = (await R.getJSON("/api/v1/runs/" + runId)).body;
      if (summary.wing_id !== null && !wing) wing = (await R.getJSON("/api/v1/wings/" + summary.wing_id)).body;
      let fresh = false;
      while (summary.n_evaluations > evals.length) {
        const page = (await R.getJSON("/api/v1/runs/" + runId + "/evaluations?after_id=" + lastId + "&limit=5000")).body;
        if (!page.evaluations.length) break;
        evals = evals.concat(page.evaluations);
        lastId = page.last_id;
        fresh = true;
      }
      drawSummary();
      if (fresh || !document.querySelector("#history .frame, #history .empty")) {
        drawHistory(); drawEnvelope(); drawParallel(); drawTable();
      }
      state.textContent = "updated " + new Date().toLocaleTimeString();
    } catch (err) {
      state.textContent = "poll failed: " + err.message;
    }
  }
  order.addEventListener("change", drawTable);
  poll();
  setInterval(poll, 1000);
})();
