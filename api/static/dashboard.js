// romams dashboard poller: refreshes the jobs table from /api/v1/jobs every second (no dependencies).
"use strict";
(function () {
  const tbody = document.querySelector("#jobs tbody");
  const state = document.getElementById("poll-state");
  const finishedSeen = new Set();
  let initialized = false;

  function esc(s) {
    return String(s === null || s === undefined ? "" : s)
      .replace(/&/g, "&amp;").replace(/</g, "&lt;").replace(/>/g, "&gt;").replace(/"/g, "&quot;");
  }

  function row(j) {
    const pct = Math.round(100 * j.progress);
    return '<tr data-job="' + esc(j.id) + '"><td class="mono">' + esc(j.id.slice(0, 8)) + "</td><td>" +
      esc(j.kind) + '</td><td class="st st-' + esc(j.status) + '">' + esc(j.status) + "</td>" +
      '<td><div class="bar"><div class="fill" data-pct="' + pct + '"></div></div><span class="pct">' + pct +
      "%</span></td><td>" + esc(j.message) + "</td><td>" + esc(j.created_at) + "</td></tr>";
  }

  // bar widths go through the CSSOM: the Content-Security-Policy forbids inline style attributes
  function sizeBars() {
    for (const el of tbody.querySelectorAll(".fill[data-pct]")) el.style.width = el.dataset.pct + "%";
  }

  async function poll() {
    try {
      const r = await fetch("/api/v1/jobs?limit=30", { headers: { Accept: "application/json" } });
      if (!r.ok) throw new Error("HTTP " + r.status);
      const jobs = await r.json();
      tbody.innerHTML = jobs.map(row).join("");
      sizeBars();
      state.textContent = "updated " + new Date().toLocaleTimeString();
      // a job that finished since the last poll may have produced a basis, ROM or evaluation
      let fresh = false;
      for (const j of jobs) {
        if (j.status === "succeeded" && !finishedSeen.has(j.id)) {
          if (initialized) fresh = true;
          finishedSeen.add(j.id);
        }
      }
      initialized = true;
      if (fresh) refreshSections();
    } catch (err) {
      state.textContent = "poll failed: " + err.message;
    }
  }

  async function refreshSections() {
    try {
      const r = await fetch("/dashboard");
      const doc = new DOMParser().parseFromString(await r.text(), "text/html");
      for (const id of ["wings-section", "evaluations-section"]) {
        const fresh = doc.getElementById(id);
        if (fresh) document.getElementById(id).replaceWith(fresh);
      }
    } catch (err) { /* the next poll retries */ }
  }

  sizeBars();
  poll();
  setInterval(poll, 1000);
})();
