// romams dashboard helpers shared by every page: escaping, relative times, the API key, cancelling a job.
"use strict";
window.romams = (function () {
  const KEY = "romams-api-key";  // the same store as dashboard.js: sessionStorage, this tab only

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

  // the API key: kept in this tab's sessionStorage (or given once as /dashboard...#key=...), sent as a Bearer token
  function storedKey() {
    const m = /(?:^#|&)key=([^&]+)/.exec(window.location.hash);
    if (m) {
      window.sessionStorage.setItem(KEY, decodeURIComponent(m[1]));
      window.history.replaceState(null, "", window.location.pathname + window.location.search);
    }
    return window.sessionStorage.getItem(KEY);
  }

  function withKey(init) {
    const key = storedKey();
    const headers = Object.assign({ Accept: "application/json" }, (init && init.headers) || {});
    if (key) headers.Authorization = "Bearer " + key;
    return Object.assign({}, init || {}, { headers: headers });
  }

  function askKey() {
    const key = window.prompt("API key (kept in this tab):", window.sessionStorage.getItem(KEY) || "");
    if (key === null) return false;
    if (key) window.sessionStorage.setItem(KEY, key.trim()); else window.sessionStorage.removeItem(KEY);
    return true;
  }

  // a page served without data (keys configured, no key on the navigation): fetch it again with the key, put its
  // main content in place and run its scripts (a script element created here runs; one set by innerHTML does not)
  async function unlock() {
    if (!storedKey() && !askKey()) return;
    const r = await fetch(window.location.href, withKey({ headers: { Accept: "text/html" } }));
    if (r.status === 401 || r.status === 403) {
      window.sessionStorage.removeItem(KEY);
      document.querySelector("main").insertAdjacentHTML("beforeend", '<p class="error">the key was refused</p>');
      return;
    }
    const doc = new DOMParser().parseFromString(await r.text(), "text/html");
    document.querySelector("main").innerHTML = doc.querySelector("main").innerHTML;
    document.body.dataset.config = doc.body.dataset.config;
    refreshTimes();
    sizeBars();
    for (const old of doc.querySelectorAll("script[src]")) {
      if (old.getAttribute("src").endsWith("/common.js")) continue;
      const tag = document.createElement("script");
      tag.src = old.getAttribute("src");
      tag.async = false;
      document.body.appendChild(tag);
    }
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
    const r = await fetch(url, withKey());
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
    const config = JSON.parse(document.body.dataset.config || "{}");
    if (config.auth && config.authorized === false && !document.getElementById("key-form")) unlock();
  });
  setInterval(refreshTimes, 10000);
  return { esc: esc, ago: ago, timeTag: timeTag, refreshTimes: refreshTimes, withKey: withKey, askKey: askKey,
           cancelJob: cancelJob, getJSON: getJSON, sizeBars: sizeBars };
})();
