// romams dashboard helpers shared by every page: escaping, relative times, the API key, cancelling a job.
"use strict";
window.romams = (function () {
  const KEY = "romams.apiKey";

  function esc(s) {
    return String(s === null || s === undefined ? "" : s)
      .replace(/&/g, "&amp;").replace(/</g, "&lt;").replace(/>/g, "&gt;").replace(/"/g, "&quot;");
  }

  // "12 s ago", "3 min ago", "2 h ago", "5 d ago" (the ISO time goes in the tooltip)
  function ago(iso) {
    if (!iso) return "";
    const s = Math.max(0, (Date.now() - Date.parse(iso)) / 1000);
    if (s < 60) return Math.round(s) + " s ago";
    if (s < 3600) return Math.round(s / 60) + " min ago";
    if (s < 86400) return Math.round(s / 3600) + " h ago";
    return Math.round(s / 86400) + " d ago";
  }

  function timeTag(iso) {
    if (!iso) return "&mdash;";
    return '<time datetime="' + esc(iso) + '" title="' + esc(iso) + '" data-rel>' + esc(ago(iso)) + "</time>";
  }

  function refreshTimes(root) {
    for (const t of (root || document).querySelectorAll("time[data-rel]")) t.textContent = ago(t.dateTime);
  }

  // the API key: kept in this browser's localStorage, sent as a Bearer token by mutating requests
  function withKey(init) {
    const key = window.localStorage.getItem(KEY);
    const headers = Object.assign({ Accept: "application/json" }, (init && init.headers) || {});
    if (key) headers.Authorization = "Bearer " + key;
    return Object.assign({}, init || {}, { headers: headers });
  }

  function askKey() {
    const key = window.prompt("API key (kept in this browser):", window.localStorage.getItem(KEY) || "");
    if (key === null) return false;
    if (key) window.localStorage.setItem(KEY, key.trim()); else window.localStorage.removeItem(KEY);
    return true;
  }

  async function cancelJob(id) {
    let r = await fetch("/api/v1/jobs/" + encodeURIComponent(id) + "/cancel", withKey({ method: "POST" }));
    if ((r.status === 401 || r.status === 403) && askKey()) {
      r = await fetch("/api/v1/jobs/" + encodeURIComponent(id) + "/cancel", withKey({ method: "POST" }));
    }
    if (!r.ok) {
      const p = await r.json().catch(() => ({}));
      window.alert("cancel failed: " + (p.detail || r.status));
    }
    return r.ok;
  }

  async function getJSON(url) {
    const r = await fetch(url, { headers: { Accept: "application/json" } });
    if (!r.ok) throw new Error("HTTP " + r.status);
    return { body: await r.json(), headers: r.headers };
  }

  function sizeBars(root) {
    for (const el of (root || document).querySelectorAll(".fill[data-pct]")) el.style.width = el.dataset.pct + "%";
  }

  document.addEventListener("DOMContentLoaded", function () {
    const b = document.getElementById("api-key");
    if (b) b.addEventListener("click", askKey);
    refreshTimes();
    sizeBars();
  });
  setInterval(refreshTimes, 10000);
  return { esc: esc, ago: ago, timeTag: timeTag, refreshTimes: refreshTimes, withKey: withKey, askKey: askKey,
           cancelJob: cancelJob, getJSON: getJSON, sizeBars: sizeBars };
})();
