// gaitcap clinic page: the "Calibrate" card (record a board sequence, show the calibration report).
// Uses api(), esc(), withToken() and state from app.js.
"use strict";

const cal = { id: null, timer: null, guideTimer: null };
const calNum = (x) => (x === null || x === undefined ? "–" : fmtNum(x));

function calError(text) { const e = document.querySelector("#calibration-error"); e.textContent = text || ""; e.hidden = !text; }
function calStatus(text) { document.querySelector("#calibration-status").textContent = text; }
function calButtons(recording) {
  document.querySelector("#calibrate").disabled = recording;
  document.querySelector("#calibrate-stop").disabled = !recording;
}

async function calibrateStart() {
  calError("");
  try {
    const run = await api("/calibrations/record/start", { method: "POST" });
    cal.id = run.id; calButtons(true);
    calStatus("Recording the board… lay it on the floor, walk it through the room, then press Stop.");
    if (!cal.guideTimer) followGuide();
    document.querySelector("#calibration-report").hidden = true;
  } catch (e) { calError(e.message); }
}

async function calibrateStop() {
  calError("");
  try {
    const run = await api("/calibrations/record/stop", { method: "POST" });
    cal.id = run.id; calButtons(false); calStatus("Calibrating…"); followCalibration();
  } catch (e) { calError(e.message); }
}

// While the board records: per camera the board views in each cell of its image, per pair of cameras the
// moments both saw it, and where to move the board (GET /calibrations/record/coverage).
function guideGrid(c) {
  const cells = c.cells.flat().map((n) => `<span class="${n ? "cal-cell-seen" : "cal-cell-empty"}" title="${n} board views">${n}</span>`);
  return `<figure><div class="cal-grid" style="grid-template-columns: repeat(${c.cells.length}, 1fr)">${cells.join("")}</div>
    <figcaption>${esc(c.name)}: ${c.views} ${c.views === 1 ? "view" : "views"} in ${c.looked} frames looked at</figcaption></figure>`;
}

function guidePairs(cov) {
  const names = cov.cameras.map((c) => c.name), together = {};
  cov.pairs.forEach((p) => { together[p.cameras.join(" ")] = together[[...p.cameras].reverse().join(" ")] = p.together; });
  const cell = (a, b) => (a === b ? "<td>–</td>" : `<td class="${together[a + " " + b] ? "" : "cal-fail"}">${together[a + " " + b]}</td>`);
  document.querySelector("#calibration-pairs thead").innerHTML = `<tr><th></th>${names.map((n) => `<th>${esc(n)}</th>`).join("")}</tr>`;
  document.querySelector("#calibration-pairs tbody").innerHTML = names.map((a) =>
    `<tr><th>${esc(a)}</th>${names.map((b) => cell(a, b)).join("")}</tr>`).join("");
}

async function showGuide() {
  const guide = document.querySelector("#calibration-guide");
  try {
    const cov = await api("/calibrations/record/coverage");
    document.querySelector("#calibration-advice").innerHTML = cov.advice.map((a) => `<li>${esc(a)}</li>`).join("");
    document.querySelector("#calibration-grids").innerHTML = cov.cameras.map(guideGrid).join("");
    guidePairs(cov);
    guide.hidden = false;
    return true;
  } catch (e) { guide.hidden = true; return false; }  // the recording stopped (409), or views are not followed (503)
}

function followGuide() {  // every second until the board recording stops
  cal.guideTimer = true;
  showGuide().then((on) => { cal.guideTimer = on ? setTimeout(followGuide, 1000) : null; });
}

function followCalibration() {
  clearTimeout(cal.timer);
  api("/calibrations/" + encodeURIComponent(cal.id)).then((run) => {
    if (run.state === "recording") { calButtons(true); calStatus("Recording the board…"); if (!cal.guideTimer) followGuide(); }
    else if (run.state === "calibrating") {
      calButtons(false); document.querySelector("#calibration-guide").hidden = true;
      calStatus(`Calibrating: ${run.stage || "waiting"} (${Math.round(100 * (run.progress || 0))} %)`);
    } else { calButtons(false); showCalibration(run); loadCalibrations(); return; }
    cal.timer = setTimeout(followCalibration, 1000);
  }).catch((e) => { calError(e.message); cal.timer = setTimeout(followCalibration, 3000); });
}

function showCalibration(run) {
  const ok = run.state === "done";
  calStatus(ok ? (run.active ? "Calibration passed: the next trials use it." : "Calibration passed.")
               : "Calibration failed: it is not used.");
  calError(ok ? "" : run.error);
  const rep = run.report || {};
  const rows = (rep.cameras || []).map((c) => `<tr><td>${esc(c.name)}</td>
    <td class="${c.ok ? "cal-pass" : "cal-fail"}">${c.ok ? "pass" : "FAIL"}</td><td>${c.n_detections}</td>
    <td>${calNum(c.reprojection_mean_px)}</td><td>${calNum(c.reprojection_p95_px)}</td>
    <td>${Number.isFinite(c.coverage) ? Math.round(100 * c.coverage) + " %" : "–"}</td><td>${esc((c.problems || []).join("; "))}</td>
    <td class="muted">${esc((c.notes || []).join("; "))}</td></tr>`);
  document.querySelector("#calibration-table tbody").innerHTML = rows.join("");
  const link = run.has_toml ? ` <a href="${withToken("/calibrations/" + encodeURIComponent(run.id) + "/toml")}">Download calibration (TOML)</a>` : "";
  const square = rep.square_mm ? `Board square ${calNum(rep.square_measured_mm)} mm measured vs ${fmtNum(rep.square_mm)} mm `
    + `(${rep.square_residual_pct >= 0 ? "+" : ""}${calNum(rep.square_residual_pct)} %); ` : "";
  const board = rep.board_used ? `Board used: ${rep.board_used}. ` : "";
  document.querySelector("#calibration-summary").innerHTML = esc(`${run.id}: ${board}${square}`
    + (rep.reprojection_rms_px !== undefined && rep.reprojection_rms_px !== null ? `reprojection RMS ${calNum(rep.reprojection_rms_px)} px.` : "")) + link;
  document.querySelector("#calibration-report").hidden = !rows.length && !run.has_toml;
  showBoardFound(ok ? [] : rep.detections || []);
}

// A calibration refused before any camera was calibrated: what each camera saw of the board.
function boardFoundRow(d) {
  const seen = d.seen ? `${d.with_board} of ${d.frames} frames` : `not seen (${d.frames} frames searched)`;
  const result = !d.seen ? "not seen" : d.usable < d.needed ? "too few views"
    : d.positions < d.needed ? `too few positions (${d.positions})` : "enough views";
  return `<tr><td>${esc(d.name)}</td><td>${seen}</td><td>${d.usable} (need ${d.needed})</td>
    <td class="${result === "enough views" ? "cal-pass" : "cal-fail"}">${result}</td>
    <td>${esc((d.advice || []).join("; "))}</td></tr>`;
}

function showBoardFound(detections) {
  document.querySelector("#calibration-found tbody").innerHTML = detections.map(boardFoundRow).join("");
  document.querySelector("#calibration-found-wrap").hidden = !detections.length;
}

async function loadCalibrations() {
  try {
    const list = await api("/calibrations?limit=20");
    const active = list.find((c) => c.active);
    document.querySelector("#calibration-active").textContent = active ? `(in use: ${active.id})` : "(none in use)";
    const rec = list.find((c) => c.state === "recording" || c.state === "calibrating");
    if (rec && !cal.id) { cal.id = rec.id; followCalibration(); }
  } catch (e) { /* not signed in yet */ }
}

document.querySelector("#calibrate").onclick = calibrateStart;
document.querySelector("#calibrate-stop").onclick = calibrateStop;
setInterval(() => { if (state.user && !document.querySelector("#app").hidden && !document.querySelector("#calibrate-card").hidden) loadCalibrations(); }, 3000);
