// Run list: one row per run (its batches are not listed one by one), refreshed every 2 s.
"use strict";
(function () {
  const R = window.romams;
  const tbody = document.querySelector("#runs tbody");
  const state = document.getElementById("poll-state");

  function num(x, d) { return x === null || x === undefined ? "&mdash;" : Number(x).toPrecision(d || 4); }

  function row(r) {
    return '<tr data-run="' + r.id + '"><td><a href="/dashboard/runs/' + r.id + '">' + r.id + "</a></td><td>" +
      '<a href="/dashboard/runs/' + r.id + '">' + R.esc(r.name) + "</a></td><td>" + R.esc(r.wing_id) + "</td>" +
      '<td class="st st-' + R.esc(r.status) + '">' + R.esc(r.status) + "</td><td>" + r.n_evaluations + "</td><td>" +
      r.n_feasible + "</td><td>" + r.n_infeasible + "</td><td>" + num(r.best_objective) + "</td><td>" +
      R.timeTag(r.created_at) + "</td></tr>";
  }

  async function load() {
    try {
      const res = await R.getJSON("/api/v1/runs?limit=100");
      tbody.innerHTML = res.body.map(row).join("") || '<tr><td colspan="9">no run yet</td></tr>';
      state.textContent = "updated " + new Date().toLocaleTimeString();
    } catch (err) {
      state.textContent = "poll failed: " + err.message;
    }
  }
  load();
  setInterval(load, 2000);
})();
