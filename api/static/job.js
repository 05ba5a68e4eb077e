// Job detail: status, progress and message refreshed every second while the job is active (the page reloads once
// when it ends, to show its result, error and traceback); the cancel button sends the API key when one is stored.
"use strict";
(function () {
  const R = window.romams;
  const section = document.getElementById("job");
  const id = section.dataset.job;
  const cancel = document.getElementById("cancel");
  const FINAL = ["succeeded", "failed", "cancelled"];

  if (cancel) cancel.addEventListener("click", async function () { if (await R.cancelJob(id)) poll(); });

  async function poll() {
    try {
      const j = (await R.getJSON("/api/v1/jobs/" + encodeURIComponent(id))).body;
      const st = document.getElementById("job-status");
      st.textContent = j.status;
      st.className = "st st-" + j.status;
      const pct = Math.round(100 * j.progress);
      document.getElementById("job-pct").textContent = pct + "%";
      section.querySelector(".fill").dataset.pct = String(pct);
      R.sizeBars(section);
      document.getElementById("job-message").textContent = j.message;
      if (FINAL.indexOf(j.status) >= 0 && FINAL.indexOf(section.dataset.status) < 0) window.location.reload();
    } catch (err) { /* the next poll retries */ }
  }
  if (FINAL.indexOf(section.dataset.status) < 0) setInterval(poll, 1000);
})();
