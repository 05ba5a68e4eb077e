// Job list: filters (status, kind, wing, run) kept in the page URL, pages of 25, relative times, cancel buttons.
// Batches of runs are listed only when filtered by run (a run page links to them), so DE generations do not flood it.
"use strict";
(function () {
  const R = window.romams;
  const PAGE = 25;
  const form = document.getElementById("job-filters");
  const tbody = document.querySelector("#jobs tbody");
  const info = document.getElementById("page-info");
  const state = document.getElementById("poll-state");
  let offset = 0;
  let total = 0;

  const params = new URLSearchParams(window.location.search);
  for (const el of form.elements) {
    if (!params.has(el.name)) continue;
    if (el.type === "checkbox") el.checked = params.get(el.name) === "true"; else el.value = params.get(el.name);
  }
  offset = Math.max(0, parseInt(params.get("offset") || "0", 10) || 0);

  function query() {
    const q = new URLSearchParams();
    for (const el of form.elements) {
      if (el.type === "checkbox") { if (el.checked) q.set(el.name, "true"); } else if (el.value.trim()) q.set(el.name, el.value.trim());
    }
    return q;
  }

  function row(j) {
    const pct = Math.round(100 * j.progress);
    const active = j.status === "queued" || j.status === "running";
    return '<tr data-job="' + R.esc(j.id) + '"><td><a class="mono" href="/dashboard/jobs/' + R.esc(j.id) + '">' +
      R.esc(j.id.slice(0, 8)) + "</a></td><td>" + R.esc(j.kind) + '</td><td class="st st-' + R.esc(j.status) + '">' +
      R.esc(j.status) + '</td><td><div class="bar"><div class="fill" data-pct="' + pct + '"></div></div><span class="pct">' +
      pct + "%</span></td><td>" + R.esc(j.message) + "</td><td>" + R.esc(j.wing_id) + "</td><td>" +
      (j.run_id === null ? "" : '<a href="/dashboard/runs/' + j.run_id + '">' + j.run_id + "</a>") + "</td><td>" +
      R.timeTag(j.created_at) + "</td><td>" +
      (active ? '<button type="button" class="cancel" data-cancel="' + R.esc(j.id) + '">cancel</button>' : "") + "</td></tr>";
  }

  async function load() {
    const q = query();
    const api = new URLSearchParams(q);
    if (!api.has("run_id")) api.set("include_runs", "false");
    api.set("limit", String(PAGE));
    api.set("offset", String(offset));
    try {
      const res = await R.getJSON("/api/v1/jobs?" + api.toString());
      total = parseInt(res.headers.get("X-Total-Count") || "0", 10);
      tbody.innerHTML = res.body.map(row).join("") || '<tr><td colspan="9">no job matches</td></tr>';
      R.sizeBars(tbody);
      const pages = Math.max(1, Math.ceil(total / PAGE));
      info.textContent = "page " + (Math.floor(offset / PAGE) + 1) + " of " + pages + " (" + total + " jobs)";
      document.getElementById("prev").disabled = offset === 0;
      document.getElementById("next").disabled = offset + PAGE >= total;
      state.textContent = "updated " + new Date().toLocaleTimeString();
    } catch (err) {
      state.textContent = "poll failed: " + err.message;
    }
  }

  function go() {
    const q = query();
    if (offset) q.set("offset", String(offset));
    window.history.replaceState(null, "", "?" + q.toString());
    load();
  }

  form.addEventListener("input", function () { offset = 0; go(); });
  form.addEventListener("submit", function (ev) { ev.preventDefault(); });
  document.getElementById("prev").addEventListener("click", function () { offset = Math.max(0, offset - PAGE); go(); });
  document.getElementById("next").addEventListener("click", function () { offset += PAGE; go(); });
  tbody.addEventListener("click", async function (ev) {
    const id = ev.target.dataset && ev.target.dataset.cancel;
    if (id && await R.cancelJob(id)) load();
  });
  load();
  setInterval(load, 2000);
})();
