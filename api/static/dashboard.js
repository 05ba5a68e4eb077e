// romams dashboard poller: refreshes the runs and jobs tables every second (no dependencies but common.js).
// With API keys configured (data-config auth: true) every request carries a read key: the key is taken from the
// URL fragment (/dashboard#key=...; removed from the address bar at once) or asked for, and kept in
// sessionStorage (this tab only); plots are fetched with it and shown as blob: URLs.
"use strict";
(function () {
  const tbody = document.querySelector("#jobs tbody");
  const state = document.getElementById("poll-state");
  const form = document.getElementById("key-form");
  const config = JSON.parse(document.body.dataset.config || "{}");
  const STORE = "romams-api-key";  // shared with common.js
  const finishedSeen = new Set();
  let initialized = false;
  let key = null;

  const esc = window.romams.esc;
  const runsBody = document.querySelector("#runs tbody");

  function row(j) {
    const pct = Math.round(100 * j.progress);
    return '<tr data-job="' + esc(j.id) + '"><td><a class="mono" href="/dashboard/jobs/' + esc(j.id) + '">' +
      esc(j.id.slice(0, 8)) + "</a></td><td>" +
      esc(j.kind) + '</td><td class="st st-' + esc(j.status) + '">' + esc(j.status) + "</td>" +
      '<td><div class="bar"><div class="fill" data-pct="' + pct + '"></div></div><span class="pct">' + pct +
      "%</span></td><td>" + esc(j.message) + "</td><td>" + window.romams.timeTag(j.created_at) + "</td></tr>";
  }

  function runRow(r) {
    const best = r.best_objective === null ? "&mdash;" : Number(r.best_objective).toPrecision(4);
    return '<tr data-run="' + r.id + '"><td><a href="/dashboard/runs/' + r.id + '">' + r.id + "</a></td><td>" +
      '<a href="/dashboard/runs/' + r.id + '">' + esc(r.name) + '</a></td><td class="st st-' + esc(r.status) + '">' +
      esc(r.status) + "</td><td>" + r.n_evaluations + "</td><td>" + r.n_feasible + "</td><td>" + best + "</td><td>" +
      window.romams.timeTag(r.created_at) + "</td></tr>";
  }

  // bar widths go through the CSSOM: the Content-Security-Policy forbids inline style attributes
  function sizeBars() {
    for (const el of tbody.querySelectorAll(".fill[data-pct]")) el.style.width = el.dataset.pct + "%";
  }

  function headers(accept) {
    const h = { Accept: accept };
    if (key) h.Authorization = "Bearer " + key;
    return h;
  }

  // a 401/403: forget the key and ask for another one
  function askForKey(message) {
    key = null;
    sessionStorage.removeItem(STORE);
    document.getElementById("key-error").textContent = message || "";
    form.hidden = false;
  }

  function keyFromFragment() {
    const m = /(?:^#|&)key=([^&]+)/.exec(location.hash);
    if (!m) return;
    sessionStorage.setItem(STORE, decodeURIComponent(m[1]));
    history.replaceState(null, "", location.pathname + location.search);
  }

  // plots of a page rendered for a key: <img data-src> fetched with the key (an <img> cannot send a header)
  async function loadImages(root) {
    for (const img of root.querySelectorAll("img[data-src]")) {
      const src = img.dataset.src;
      img.removeAttribute("data-src");
      try {
        const r = await fetch(src, { headers: headers("image/*") });
        if (r.ok) img.src = URL.createObjectURL(await r.blob());
      } catch (err) { /* a missing plot stays empty */ }
    }
  }

  async function poll() {
    if (config.auth && !key) return;
    try {
      const r = await fetch("/api/v1/jobs?limit=30&include_runs=false", { headers: headers("application/json") });
      if (r.status === 401 || r.status === 403) return askForKey("the key was refused (HTTP " + r.status + ")");
      if (!r.ok) throw new Error("HTTP " + r.status);
      const jobs = await r.json();
      tbody.innerHTML = jobs.map(row).join("");
      const runs = await fetch("/api/v1/runs?limit=10", { headers: headers("application/json") });
      if (runs.ok) runsBody.innerHTML = (await runs.json()).map(runRow).join("") || '<tr><td colspan="7">no run yet</td></tr>';
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
      const r = await fetch("/dashboard", { headers: headers("text/html") });
      if (r.status === 401 || r.status === 403) return askForKey("the key was refused (HTTP " + r.status + ")");
      const doc = new DOMParser().parseFromString(await r.text(), "text/html");
      for (const id of ["wings-section", "evaluations-section"]) {
        const fresh = doc.getElementById(id);
        if (fresh) {
          document.getElementById(id).replaceWith(fresh);
          loadImages(fresh);
        }
      }
    } catch (err) { /* the next poll retries */ }
  }

  form.addEventListener("submit", function (ev) {
    ev.preventDefault();
    key = document.getElementById("key-input").value.trim();
    sessionStorage.setItem(STORE, key);
    form.hidden = true;
    refreshSections();
    poll();
  });

  sizeBars();
  if (config.auth) {
    keyFromFragment();
    key = sessionStorage.getItem(STORE);
    if (!key) askForKey("");
    else if (!config.authorized) refreshSections();  // the page came without data: fetch it with the key
    else loadImages(document);
  }
  poll();
  setInterval(poll, 1000);
})();
