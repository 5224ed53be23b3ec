// gaitcap clinic page: the rig check of the latest processed trial, in the record card (every role that
// records sees it, not only those who calibrate), so a camera bumped since calibration is seen before the
// next patient; the refined calibration's Reprocess button stays in the calibration card. Uses api(), esc(), fmtNum() and state from app.js.
"use strict";

const rigNum = (x, digits) => (x === null || x === undefined ? "–" : Number(x).toFixed(digits));
// An estimate with how far this trial lets it be off ("1.5 ± 4.5"); the bound alone is shown as stored
// (rotation: the largest over the camera's axes); checks stored before the bounds show the estimate only.
const rigBound = (bound) => (Array.isArray(bound) ? Math.max(...bound) : bound);
const rigEstimate = (x, bound, digits) => (bound === null || bound === undefined || x === null || x === undefined
  ? rigNum(x, digits) : `${rigNum(x, digits)} ± ${rigNum(rigBound(bound), digits)}`);

function rigCheckRow(c) {
  const result = !c.judged ? "not judged" : (c.moved ? "MOVED" : "in place");
  return `<tr><td>${esc(c.name)}</td><td class="${c.moved ? "cal-fail" : (c.judged ? "cal-pass" : "")}">${result}</td>
    <td>${rigEstimate(c.rotation_deg, c.rotation_bound_deg, 2)}</td><td>${rigEstimate(c.shift_mm, c.shift_bound_mm, 1)}</td>
    <td>${rigNum(c.field_px, 2)}</td></tr>`;
}

function rigCheckSummary(check) {
  const when = new Date(check.checked_at * 1000).toLocaleString();
  const against = check.baseline_trial ? `, judged by the change since trial ${check.baseline_trial}` : "";
  const seen = `trial ${check.trial_id} (patient ${check.subject_id}, checked ${when}${against})`;
  if (!check.flagged) return `No camera moved since calibration: ${seen}.`;
  const moved = check.cameras.filter((c) => c.moved)
    .map((c) => `${c.name} (about ${rigEstimate(c.rotation_deg, c.rotation_bound_deg, 1)} deg, `
      + `${rigEstimate(c.shift_mm, c.shift_bound_mm, 0)} mm)`).join(", ");
  return `Camera ${moved} moved since calibration, seen in ${seen}. Recalibrate, or refine the rig from `
    + "people (gaitcap refine-rig), before the next patient.";
}

function showRigCheck(check) {
  const box = document.querySelector("#rig-check");
  box.hidden = !check;
  if (!check) return;
  const summary = document.querySelector("#rig-check-summary");
  summary.textContent = rigCheckSummary(check);
  summary.className = check.flagged ? "error" : "muted";
  document.querySelector("#rig-check-table tbody").innerHTML = check.cameras.map(rigCheckRow).join("");
}

async function loadRigCheck() {
  try { showRigCheck(await api("/rig-check/latest")); }
  catch (e) { if (e.status === 404) showRigCheck(null); }
}

// A calibration refined from people that is in use but not applied yet: how far each camera moved, and the
// one button that reprocesses the trials that used the calibration it replaces.
function showCalibrationVersion(version) {
  const box = document.querySelector("#calibration-version");
  const open = !!version && version.applied_at === null && version.trials_using_replaced.length > 0;
  box.hidden = !open;
  if (!open) return;
  const moved = Object.entries(version.comparison)
    .map(([name, c]) => `${name} ${rigNum(c.rotation_deg, 2)} deg, ${rigNum(c.centre_mm, 1)} mm`).join("; ");
  document.querySelector("#calibration-version-text").textContent =
    `Calibration ${version.id} (refined from people, replacing ${version.replaces}) is in use: ${moved}. `
    + `${version.trials_using_replaced.length} earlier trial(s) used ${version.replaces}.`;
  const button = document.querySelector("#calibration-version-apply");
  button.dataset.id = version.id;
  button.textContent = `Reprocess ${version.trials_using_replaced.length} trial(s) with it`;
}

async function loadCalibrationVersion() {
  try {
    const active = await api("/calibrations/latest");
    showCalibrationVersion(await api("/calibrations/" + encodeURIComponent(active.id) + "/version"));
  } catch (e) { if (e.status === 404) showCalibrationVersion(null); }
}

async function applyCalibrationVersion() {
  const button = document.querySelector("#calibration-version-apply");
  const status = document.querySelector("#calibration-version-status");
  button.disabled = true;
  try {
    const r = await api("/calibrations/" + encodeURIComponent(button.dataset.id) + "/apply", { method: "POST" });
    status.textContent = `${r.queued.length} trial(s) queued for processing again`
      + (r.skipped.length ? `; not finished yet: ${r.skipped.join(", ")}` : "") + ".";
  } catch (e) { status.textContent = e.message; }
  button.disabled = false;
}

document.querySelector("#calibration-version-apply").onclick = applyCalibrationVersion;

function rigCheckTick() {
  if (!state.user || document.querySelector("#app").hidden) return;
  const records = !document.querySelector("#record").hidden, calibrates = !document.querySelector("#calibrate-card").hidden;
  if (records || calibrates) loadRigCheck();
  if (calibrates) loadCalibrationVersion();
}
setInterval(rigCheckTick, 3000);
