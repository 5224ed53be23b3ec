// gaitcap clinic page: plain JS, no build step. Signed in by the session cookie (HttpOnly; set by /login).
"use strict";

const $ = (sel) => document.querySelector(sel);
const state = { user: null, recording: null, followed: null, shownResult: null, cameras: {}, statusWs: null, busy: false, rerun: null };

// ---------- session ----------
async function api(path, options = {}) {
  const headers = Object.assign({}, options.headers || {});
  if (options.body && typeof options.body !== "string") {
    options.body = JSON.stringify(options.body);
    headers["Content-Type"] = "application/json";
  }
  const res = await fetch(path, Object.assign({ credentials: "same-origin" }, options, { headers }));
  if (res.status === 401) { showLogin(state.user ? "You were signed out. Please sign in again." : ""); state.user = null; throw new Error("not signed in"); }
  if (!res.ok) {
    let msg = res.status + " " + res.statusText;
    try { const body = await res.json(); if (body.detail) msg = typeof body.detail === "string" ? body.detail : JSON.stringify(body.detail); } catch (e) { /* not JSON */ }
    const err = new Error(msg); err.status = res.status; throw err;
  }
  return res.headers.get("content-type")?.includes("json") ? res.json() : res.text();
}

function withToken(url) { return url; }  // downloads and images carry the session cookie

function showLogin(message) {
  $("#app").hidden = true; $("#login").hidden = false;
  const e = $("#login-error"); e.hidden = !message; e.textContent = message || "";
  if (state.statusWs) { state.statusWs.onclose = null; state.statusWs.close(); state.statusWs = null; }
}

function enterApp(me) {
  state.user = me.user;
  const can = new Set(me.permissions);  // what the user's roles allow; the server checks it again
  $("#account-name").textContent = me.user + " (" + me.roles.join(", ") + ")"; $("#account").hidden = false;
  $("#record").hidden = !can.has("record");
  $("#calibrate-card").hidden = !can.has("calibrate");
  $("#cameras-card").hidden = !can.has("live");
  $("#login").hidden = true; $("#app").hidden = false;
  connectStatus();
  if (can.has("live")) connectPreviews();
  if (typeof rigCheckTick === "function") rigCheckTick();  // the rig check at once, not 3 s later
  if (typeof loadRooms === "function") loadRooms();
}

async function signIn(user, password) {
  const res = await fetch("/login", { method: "POST", credentials: "same-origin", headers: { "Content-Type": "application/json" },
    body: JSON.stringify({ user, password }) });
  if (res.status === 401) throw new Error("The user name or password is not right.");
  if (res.status === 429) throw new Error("Too many failed attempts. Please wait a few minutes.");
  if (!res.ok) throw new Error(res.status + " " + res.statusText);
  enterApp(await res.json());
}

async function signOut() {
  await fetch("/logout", { method: "POST", credentials: "same-origin" });
  state.user = null; $("#account").hidden = true; showLogin("You are signed out.");
}

// ---------- messages ----------
function showError(text) { const e = $("#error"); e.textContent = text; e.hidden = !text; state.refused = false; }

function clearRefusal(words, listed) {
  // a "Start refused" message goes once every camera works again (it said what was wrong with them)
  if (!state.refused || !listed || !words.ok || state.recording || state.busy) return;
  showError("");
  setStatus("Ready: the cameras are working again. Enter the patient ID and press Start.");
}
function setStatus(text, recording) {
  // the status is an aria-live region: written only when its words change (the timer beside it is not announced)
  const s = $("#record-status");
  if (s.textContent !== text) s.textContent = text;
  s.parentElement.classList.toggle("recording", !!recording);
  if (!recording) $("#record-timer").textContent = "";
}

// ---------- start / stop ----------
async function startTrial() {
  showError("");
  const subject = $("#subject").value.trim();
  if (!subject) { showError("Please enter the patient ID (a pseudonym such as P0042) before starting."); $("#subject").focus(); return; }
  if (!checkFields()) return;
  state.busy = true; $("#start").disabled = true;
  setStatus("Starting the recording…");
  try {
    const body = { subject_id: subject, session: $("#session").value.trim() || undefined };
    let trial;
    try {
      trial = await api("/trials", { method: "POST", body: Object.assign({}, body) });
    } catch (e) {
      // the rig check refused: say why, and record only if the clinician confirms (the override is audited)
      if (e.status !== 409 || !e.message.startsWith("Start refused")) throw e;
      if (!e.message.includes("override_rig_check")) {  // nothing to record (no camera delivers images): no "anyway"
        showError(e.message); state.refused = true; setStatus("Not recording: " + e.message.replace(/^Start refused: /, ""));
        state.busy = false; renderRecording(); return;
      }
      if (!confirm(e.message.replace(". To record anyway, confirm (override_rig_check).", ".") + "\n\nRecord anyway? The results will carry a warning.")) {
        showError(e.message.replace(" To record anyway, confirm (override_rig_check).", "")); state.refused = true; setStatus("Not recording.");
        state.busy = false; renderRecording(); return;
      }
      trial = await api("/trials", { method: "POST", body: Object.assign({ override_rig_check: true }, body) });
    }
    state.recording = trial; state.followed = null; renderRecording();
    saveClinicalFields(trial.id);
  } catch (e) {
    if (e.status === 409) showError("Another recording is already running: " + e.message);
    else if (e.status === 422) showError("Please check the form: " + e.message);
    else if (e.status === 503) showError("The cameras or the recorder are not ready: " + e.message);
    else if (e.status === 507) showError("The recordings cannot be saved: " + e.message);
    else showError("Could not start: " + e.message);
    setStatus("Not recording.");
  }
  state.busy = false; renderRecording();
}

async function stopTrial() {
  if (!state.recording) return;
  showError("");
  state.busy = true; $("#stop").disabled = true;
  setStatus("Stopping and saving the recording…");
  try {
    const trial = await api("/trials/" + encodeURIComponent(state.recording.id) + "/stop", { method: "POST" });
    state.recording = null;
    if (trial.catalog_unreachable) setStatus("Saved. The catalog is unreachable: " + trial.detail + ".");  // 202
    else { follow(trial.id); setStatus("Saved. Computing the results…"); }
  } catch (e) {
    showError(e.status === 503 ? "The recorder is not answering. The recording is kept and will be recovered and processed: " + e.message
      : "Could not stop: " + e.message);
    if (e.status === 503) { const id = state.recording.id; state.recording = null; follow(id); }
  }
  state.busy = false; renderRecording();
}

function renderRecording() {
  const rec = state.recording;
  $("#start").disabled = !!rec || state.busy; $("#stop").disabled = !rec || state.busy;
  $("#subject").disabled = !!rec; $("#session").disabled = !!rec;
  if (rec) {
    const secs = Math.max(0, Date.now() / 1000 - rec.started_at);
    setStatus(`Recording patient ${rec.subject_id}. Press Stop when the walk is finished.`, true);
    $("#record-timer").textContent = fmtDuration(secs);
  }
}

// ---------- live status ----------
function connectStatus() {
  const proto = location.protocol === "https:" ? "wss" : "ws";
  const ws = new WebSocket(`${proto}://${location.host}/ws/status`);
  state.statusWs = ws;
  ws.onopen = () => setConnection(true);
  ws.onmessage = (ev) => onStatus(JSON.parse(ev.data));
  ws.onclose = () => { setConnection(false); if (state.statusWs === ws) setTimeout(connectStatus, 1000); };
}

function setConnection(ok) {
  const c = $("#connection");
  c.textContent = ok ? "Connected" : "Connection lost – retrying…";
  c.className = "pill " + (ok ? "pill-ok" : "pill-bad");
}

function onStatus(snap) {
  const wasRecording = state.recording;
  // a snapshot taken before our own Start answered must not end the recording on the page
  const stale = !snap.recording && wasRecording && snap.time < wasRecording.started_at + 0.5
    && !snap.trials.some((t) => t.id === wasRecording.id && t.state !== "recording");
  state.recording = stale ? wasRecording : snap.recording;
  if (!state.recording && wasRecording && !state.busy) {
    // stopped elsewhere (another tab, another user, the recorder's guard): no stale "Recording" line
    setStatus("The recording was stopped (in another tab or by the system). Computing the results…");
  }
  if (!state.recording && wasRecording && !state.followed) follow(wasRecording.id);
  renderRecording();
  if (typeof roomFilterActive !== "function" || !roomFilterActive()) renderTrials(snap.trials);  // rooms.js
  renderCameras(snap.cameras, snap.detection);
  const followed = snap.trials.find((t) => t.id === state.followed);
  if (followed) updateFollowed(followed);
}

function renderTrials(trials) {
  // updated in place: a row is rewritten only when its trial changed, so focus and clicks stay where they are
  const body = $("#trials tbody");
  if (!trials.length) {
    if (!body.querySelector(".empty")) body.innerHTML = '<tr class="empty"><td colspan="6" class="muted">No trials yet.</td></tr>';
    keepTableRoles($("#trials")); return;
  }
  body.querySelector(".empty")?.remove();
  const rows = new Map([...body.querySelectorAll("tr[data-trial]")].map((tr) => [tr.dataset.trial, tr]));
  const wanted = new Set(trials.map((t) => t.id));
  for (const [id, tr] of rows) if (!wanted.has(id)) tr.remove();
  let before = body.firstElementChild;
  for (const t of trials) {
    let tr = rows.get(t.id);
    if (!tr) { tr = document.createElement("tr"); tr.dataset.trial = t.id; }
    const cells = trialCells(t), key = JSON.stringify(cells);
    if (tr.dataset.key !== key) {
      tr.dataset.key = key;
      tr.classList.toggle("voided", !!t.voided);
      if (tr.children.length !== 6) tr.innerHTML = TRIAL_COLUMNS.map(([label, cls]) => `<td data-label="${label}" class="${cls}"></td>`).join("");
      cells.forEach((html, i) => { if (i < 5 && tr.children[i].innerHTML !== html) tr.children[i].innerHTML = html; });
      const hasButton = !!tr.children[5].querySelector(".view");
      if (hasButton !== !!cells[5]) {
        tr.children[5].innerHTML = cells[5];
        const btn = tr.children[5].querySelector(".view");
        if (btn) btn.onclick = () => { follow(t.id); showResults(); };
      }
    }
    if (tr !== before) body.insertBefore(tr, before); else before = before.nextElementSibling;
  }
  keepTableRoles($("#trials"));
}

// a list shown as cards below 900 px (table.stack) stays a table to screen readers: the roles said outright,
// as some browsers drop a table's own roles once its display is changed
function keepTableRoles(table) {
  table.setAttribute("role", "table");
  for (const [sel, role] of [["thead, tbody", "rowgroup"], ["tr", "row"], ["th", "columnheader"], ["td", "cell"]])
    for (const el of table.querySelectorAll(`:is(${sel}):not([role])`)) el.setAttribute("role", role);
}

// the trial list's columns: the label each cell carries when a narrow screen stacks a row's cells
const TRIAL_COLUMNS = [["Started", "when"], ["Patient", "id-cell"], ["Session", "id-cell"], ["Length", ""], ["State", "wide"], ["", "wide"]];

function trialCells(t) {
  const progress = t.state === "processing" ? ` <progress max="1" value="${t.progress}"></progress>` : "";
  return [fmtTime(t.started_at || t.created_at), esc(t.subject_id), esc(t.session),
    t.duration_s == null ? "" : fmtDuration(t.duration_s),
    `<span class="state state-${t.state}">${esc(t.state_text)}</span>${progress}${t.error ? `<div class="error">${esc(t.error)}</div>` : ""}${t.warnings.length ? `<div class="warning-count">${t.warnings.length} warning${t.warnings.length > 1 ? "s" : ""}</div>` : ""}${t.voided ? `<div class="void-note"><strong>Void:</strong> ${esc(t.void_reason)}</div>` : ""}`,
    t.results.length ? `<button class="btn view" aria-label="View results of ${esc(t.subject_id)}, ${esc(t.session)}">View results</button>` : ""];
}

// ---------- cameras ----------
function renderCameras(cams, detection) {
  const grid = $("#cameras");
  const det = (detection && detection.cameras) || {};
  const words = cameraWords(cams);
  $("#camera-summary").textContent = cams.length ? words.text : "";
  noteCameraProblem(words, cams.length > 0);
  clearRefusal(words, cams.length > 0);
  if (!cams.length) { grid.innerHTML = '<p class="muted">No cameras seen yet. Check that the cameras are switched on.</p>'; state.cameras = {}; return; }
  if (grid.querySelector("p")) grid.innerHTML = "";
  for (const c of cams) {
    let tile = state.cameras[c.name];
    if (!tile) {
      tile = document.createElement("div");
      tile.className = "camera"; tile.dataset.camera = c.name;
      tile.innerHTML = `<img alt="Camera ${esc(c.name)} preview"><div class="cap"><span class="name">${esc(c.name)}</span><span class="fps"></span></div><div class="det"></div>`;
      grid.appendChild(tile); state.cameras[c.name] = tile;
    }
    tile.className = "camera " + (c.healthy ? "ok" : "bad");
    tile.querySelector(".fps").textContent = c.healthy ? `${c.fps.toFixed(1)} fps` : `${c.status} (${c.fps.toFixed(1)} fps)`;
    const d = det[c.name];  // live detection: share of the frames with keypoints, and their lag
    tile.querySelector(".det").textContent = d && d.coverage != null
      ? `Keypoints live: ${Math.round(100 * d.coverage)} %` + (d.lag_s != null ? `, ${d.lag_s.toFixed(1)} s behind` : "") : "";
  }
}

function connectPreviews() {
  const proto = location.protocol === "https:" ? "wss" : "ws";
  const ws = new WebSocket(`${proto}://${location.host}/ws/preview?fps=4`);
  ws.binaryType = "arraybuffer";
  ws.onmessage = (ev) => {
    const bytes = new Uint8Array(ev.data);
    const name = new TextDecoder().decode(bytes.subarray(1, 1 + bytes[0]));
    const tile = state.cameras[name];
    if (!tile) return;
    const img = tile.querySelector("img");
    const url = URL.createObjectURL(new Blob([bytes.subarray(1 + bytes[0])], { type: "image/jpeg" }));
    const old = img.src; img.src = url; if (old.startsWith("blob:")) URL.revokeObjectURL(old);
  };
  ws.onclose = () => setTimeout(connectPreviews, 2000);
}

// ---------- results ----------
function showResults() {
  // "View results" far down the list: bring the results into view and move the focus there
  $("#results-heading").focus({ preventScroll: true });
  $("#results").scrollIntoView({ block: "start" });
}

function markVoidResults(voided, reason) {
  // a void trial's results are struck through, its stage label red, and a VOID banner is printed, on every
  // printed page too (a page margin box: a sheet printed alone must not look valid)
  $("#results").classList.toggle("voided", !!voided);
  let style = $("#void-print");
  if (!style) { style = document.createElement("style"); style.id = "void-print"; document.head.append(style); }
  const words = "VOID - not for clinical use" + (reason ? ": " + String(reason).replace(/["\\\n\r]/g, " ").slice(0, 90) : "");
  const css = voided ? `@media print { @page { @top-center { content: "${words}"; color: #8a1111; font: bold 11pt sans-serif; } } }` : "";
  if (style.textContent !== css) style.textContent = css;
}

function follow(trialId) {
  state.followed = trialId; state.shownResult = null;
  $("#results").hidden = false;
  $("#results-title").textContent = "trial " + trialId; $("#results-patient").textContent = ""; markVoidResults(false);
  resetSides(); if (typeof kinReset === "function") kinReset("");
  $("#results-stage").textContent = "Computing the results… the first numbers appear a few seconds after Stop.";
  $("#results-stage").className = "stage";
  $("#results-summary").innerHTML = ""; $("#results-summary").dataset.stage = "";
  $("#steps-table thead").innerHTML = ""; $("#steps-table tbody").innerHTML = "";
  $("#report-plot").removeAttribute("src"); $("#downloads").innerHTML = "";
  renderWarnings([], null); $("#results-summary").classList.remove("superseded");
  peopleBox().hidden = true; state.rerun = null; $("#people-status").textContent = "";
  api("/trials/" + encodeURIComponent(trialId)).then(updateFollowed).catch((e) => showError(e.message));
}

function renderWarnings(warnings, t) {
  // data-quality warnings in plain words, above the numbers; the quality line says when there are none
  const box = $("#results-warnings"), list = box.querySelector("ul");
  list.innerHTML = warnings.map((w) => `<li>${esc(w)}</li>`).join("");
  box.hidden = !warnings.length;
  const done = t && (t.state === "done" || t.state === "done_with_warnings");
  $("#results-quality").textContent = !t ? "" : warnings.length ? "" : done ? "Data quality: every check passed (cameras, sync, coverage, calibration)." : "Data quality: checked when processing ends.";
  state.warnings = warnings;
}

function updateFollowed(t) {
  renderWarnings(t.warnings || [], t);
  $("#results-patient").textContent = `Patient ${t.subject_id} · ${fmtTime(t.started_at || t.created_at)} · session ${t.session}`
    + (t.voided ? ` · VOID: ${t.void_reason}` : "");
  markVoidResults(t.voided, t.void_reason);
  if (state.rerun === t.id && !rerunFinished(t)) return;
  const best = t.results.includes("refined") ? "refined" : t.results.includes("preliminary") ? "preliminary" : null;
  if (t.state === "failed") {
    $("#results-stage").textContent = "Processing failed: " + (t.error || "unknown error") + (best ? " (showing the last results)" : "");
    $("#results-stage").className = "stage error";
  } else if (!best) {
    $("#results-stage").textContent = t.state === "recording" ? "Recording…" : `${t.state_text}… (${Math.round(100 * t.progress)} %)`;
  }
  if (best && state.shownResult !== best) { state.shownResult = best; loadResult(t.id, best, t.state); }
  // (a refused Start keeps its words on the status line until the cameras work again)
  if (!state.recording && !state.busy && !state.refused) setStatus(stageStatus(t, best) || $("#record-status").textContent);
  else if (best === "preliminary" && t.state === "processing") {
    $("#results-stage").textContent = `Preliminary results. Refining the 3D reconstruction… (${Math.round(100 * t.progress)} %)`;
  }
}

function stageStatus(t, best) {
  // the status line follows the followed trial's stages to its end (never left on "Computing" once
  // results are shown); no percentages: the line is announced when its words change
  if (t.state === "done") return "Ready for the next walk. Enter the patient ID and press Start.";
  if (t.state === "done_with_warnings") return "Ready for the next walk. The last walk's results carry data-quality warnings (see below).";
  if (t.state === "failed") return "Not recording. Processing of the last walk failed (see below).";
  if (t.state !== "recorded" && t.state !== "processing") return "";
  if (best === "refined") return "Refined results below. Finishing the trial (" + (t.stage || "checks") + ")…";
  if (best === "preliminary") return "Preliminary results below. Refining the 3D reconstruction…";
  const now = $("#record-status").textContent;  // "stopped in another tab ... Computing the results" says it already
  return now.startsWith("The recording was stopped") ? "" : "Saved. Computing the results…";
}

async function loadResult(trialId, stage, trialState) {
  const g = await api(`/trials/${encodeURIComponent(trialId)}/gait?stage=${stage}`);
  const warned = (state.warnings || []).length > 0;
  const label = stage === "refined" ? (warned ? "Results with warnings (refined 3D reconstruction): read the warnings above."
    : "Final results (refined 3D reconstruction).") : "Preliminary results. Refining the 3D reconstruction…";
  $("#results-summary").classList.remove("superseded");
  $("#results-stage").textContent = label;
  $("#results-stage").className = "stage " + stage;
  const summary = $("#results-summary");
  summary.innerHTML = "";
  for (const [name, m] of Object.entries(g.summary)) {
    if (m.mean == null) continue;
    const [text, unit] = nice(name, m.unit), s = (g.shown || {})[name] || {};  // s: the server's texts (one rounding rule)
    const sd = m.sd != null ? ` ± ${esc(s.sd ?? fmtNum(m.sd))}` : "";
    summary.insertAdjacentHTML("beforeend", `<div class="metric" data-metric="${esc(name)}"><div class="name">${esc(text)}</div>
      <div class="value">${esc(s.mean ?? fmtNum(m.mean))}<span class="unit">${sd} ${esc(unit)}</span></div></div>`);
  }
  if (!summary.children.length) summary.innerHTML = '<p class="muted">No complete steps were found in this walk.</p>';
  summary.dataset.stage = stage;
  renderSteps(g.steps);
  loadSides(trialId);
  loadPeople(trialId);
  if (typeof loadKinematics === "function") loadKinematics(trialId, stage);
  if (typeof loadValidation === "function") loadValidation(trialId);
  showPlot(withToken(`/trials/${encodeURIComponent(trialId)}/report.png?stage=${stage}`), 30);
  const names = { steps_csv: "Steps (CSV)", trajectory_csv: "3D trajectory (CSV)", trajectory_trc: "3D trajectory (TRC)",
    report_png: "Report plot (PNG)", rerun_rrd: "3D view for Rerun (.rrd)", results_mcap: "Results for Foxglove (MCAP)",
    recording_mcap: "Raw recording (MCAP)" };
  $("#downloads").innerHTML = "Downloads: " + Object.entries(names).filter(([k]) => g.downloads[k])
    .map(([k, text]) => `<a href="${withToken(g.downloads[k])}" download>${text}</a>`).join("");
}

function showPlot(url, tries) {
  // the plot is drawn just after the numbers are stored: retry for a little while
  const img = $("#report-plot");
  img.classList.add("loading");  // hidden (no broken-image text) until it loads
  img.onload = () => img.classList.remove("loading");
  img.onerror = () => { if (tries > 0) setTimeout(() => showPlot(url, tries - 1), 1000); };
  img.src = url + "&t=" + Date.now();
}

function renderSteps(steps) {
  const head = $("#steps-table thead"), body = $("#steps-table tbody");
  body.innerHTML = ""; head.innerHTML = "";
  if (!steps.length) return;
  const cols = [];
  for (const s of steps) for (const k of Object.keys(s)) if (!cols.includes(k) && (typeof s[k] !== "object" || s[k] === null)) cols.push(k);
  head.innerHTML = "<tr><th>#</th>" + cols.map((c) => { const [t, u] = nice(c, ""); return `<th>${esc(t)}${u ? " (" + esc(u) + ")" : ""}</th>`; }).join("") + "</tr>";
  steps.forEach((s, i) => {
    // a step not counted in the summary (its reason in the "excluded" column) is marked as such
    body.insertAdjacentHTML("beforeend", (s.excluded ? '<tr class="excluded-step">' : "<tr>") + "<td>" + (i + 1) + "</td>" + cols.map((c) => `<td>${typeof s[c] === "number" ? fmtNum(s[c]) : esc(String(s[c] ?? ""))}</td>`).join("") + "</tr>");
  });
}

// ---------- people in view (several people seen: which one is the patient) ----------
function peopleBox() {
  let box = $("#people");
  if (!box) {
    box = document.createElement("div");
    box.id = "people"; box.hidden = true;
    box.innerHTML = `<h3>People in view</h3>
      <p class="muted">Several people were seen in this walk. The results are for the person marked <b>Patient</b>.
        If that is the wrong person, press <b>This is the patient</b> next to the right one: the walk is then computed again.</p>
      <p id="people-status" class="stage" aria-live="polite"></p>
      <table id="people-table"><thead><tr><th>Person</th><th>Seen from – to</th><th>Seen for</th><th>Walked</th><th></th></tr></thead>
        <tbody></tbody></table>
      <div id="people-stills" hidden><p class="muted">Or click on the patient in a camera image:</p>
        <div class="camera-grid"></div></div>`;
    $("#results-stage").insertAdjacentElement("afterend", box);
  }
  return box;
}

async function loadPeople(trialId) {
  const box = peopleBox();
  let p;
  try { p = await api(`/trials/${encodeURIComponent(trialId)}/people`); } catch (e) { box.hidden = true; return; }
  if (state.followed !== trialId) return;
  box.hidden = p.people.length < 2;
  const body = box.querySelector("tbody");
  body.innerHTML = "";
  for (const person of p.people) {
    const tr = document.createElement("tr");
    tr.dataset.track = person.track_id;
    if (person.is_patient) tr.className = "patient";
    const mark = person.is_patient ? `<span class="state state-done">Patient${p.chosen_by === "clinician" ? " (your choice)" : " (chosen automatically)"}</span>`
      : '<button class="btn choose">This is the patient</button>';
    tr.innerHTML = `<td>Person ${person.track_id + 1}</td><td>${fmtNum(person.first_s)} s – ${fmtNum(person.last_s)} s</td>
      <td>${fmtNum(person.seen_s)} s</td><td>${fmtNum(person.path_mm / 1000)} m</td><td>${mark}</td>`;
    const btn = tr.querySelector(".choose");
    if (btn) btn.onclick = () => choosePatient(trialId, person.track_id);
    body.appendChild(tr);
  }
  renderStills(trialId, p);
}

function renderStills(trialId, p) {
  // one recorded image per camera at a frame with everyone in view; a click there chooses the person under it
  const wrap = $("#people-stills"), grid = wrap.querySelector(".camera-grid");
  grid.innerHTML = "";
  wrap.hidden = p.people.length < 2 || p.busiest_frame == null;
  if (wrap.hidden) return;
  for (const cam of p.cameras) {
    const size = p.image_sizes_px[cam];
    if (!size) continue;
    const tile = document.createElement("div");
    tile.className = "camera ok"; tile.dataset.camera = cam; tile.hidden = true;
    tile.innerHTML = `<div style="position: relative"><img alt="Camera ${esc(cam)} image to click on" style="cursor: crosshair">${personMarks(p, cam, size)}</div>
      <div class="cap"><span class="name">${esc(cam)}</span></div>`;
    const img = tile.querySelector("img");
    img.onload = () => { img.style.aspectRatio = `${img.naturalWidth} / ${img.naturalHeight}`; tile.hidden = false; };
    img.onerror = () => { tile.remove(); };
    img.onclick = (ev) => {
      const r = img.getBoundingClientRect();
      const x = (ev.clientX - r.left) / r.width * size[0], y = (ev.clientY - r.top) / r.height * size[1];
      choosePatient(trialId, { camera: cam, frame: p.busiest_frame, x_px: x, y_px: y });
    };
    img.src = withToken(`/trials/${encodeURIComponent(trialId)}/still/${encodeURIComponent(cam)}.jpg?frame=${p.busiest_frame}`);
    grid.appendChild(tile);
  }
}

function personMarks(p, cam, size) {
  // a labelled frame around each person in the image (the patient green), clicks pass through to the image
  const patient = p.patient_track_id;
  return ((p.boxes_px || {})[cam] || []).map(({ track_id, box_px: [x0, y0, x1, y1] }) => {
    const color = track_id === patient ? "#2e9d4f" : "#e08a00";
    const pct = (v, n) => (100 * v / n).toFixed(2) + "%";
    return `<div class="person-mark" data-track="${track_id}" style="position: absolute; pointer-events: none; border: 2px solid ${color};
      left: ${pct(x0, size[0])}; top: ${pct(y0, size[1])}; width: ${pct(x1 - x0, size[0])}; height: ${pct(y1 - y0, size[1])}">
      <span style="position: absolute; top: 0; left: 0; background: ${color}; color: #fff; font-size: 12px; padding: 0 4px; white-space: nowrap">Person ${track_id + 1}${track_id === patient ? " (patient)" : ""}</span></div>`;
  }).join("");
}

async function choosePatient(trialId, choice) {
  // choice: a track id (from the list) or a click {camera, frame, x_px, y_px} on a camera image
  showError("");
  for (const b of document.querySelectorAll("#people .choose")) b.disabled = true;
  try {
    const body = typeof choice === "number" ? { track_id: choice } : choice;
    const p = await api(`/trials/${encodeURIComponent(trialId)}/patient`, { method: "POST", body });
    const chosen = typeof choice === "number" ? choice : p.pending_choice;
    state.rerun = trialId;
    state.rerunWho = chosen == null ? "the chosen person" : `person ${chosen + 1}`;
    $("#people-status").textContent = `Computing the walk again for ${state.rerunWho}…`;
    // the numbers shown are for the previously chosen person: superseded until the new ones arrive
    $("#results-summary").classList.add("superseded"); $("#results-summary").dataset.stage = "superseded";
    $("#results-stage").textContent = "Superseded: these numbers are for the previously chosen person. New results are being computed…";
    $("#results-stage").className = "stage";
  } catch (e) {
    showError(e.status === 404 && typeof choice !== "number" ? "Nobody was found where you clicked. Please click on the person, or use the buttons in the list."
      : "Could not choose the patient: " + e.message);
    for (const b of document.querySelectorAll("#people .choose")) b.disabled = false;
  }
}

function rerunFinished(t) {
  // the results of a walk computed again for a newly chosen patient: show them once it is done
  if (state.rerun !== t.id) return false;
  if (t.state === "recorded" || t.state === "processing") {
    $("#people-status").textContent = `Computing the walk again for ${state.rerunWho || "the chosen person"}… (${Math.round(100 * t.progress)} %)`;
    return false;
  }
  state.rerun = null; state.shownResult = null;
  $("#people-status").textContent = t.state === "done" ? "Done: the results below are for the chosen person." : "";
  return true;
}

// ---------- system health (every component; shown when one is down for more than a few seconds) ----------
const COMPONENT_NAMES = { database: "Database", disk: "Disk space", recorder: "Recorder", detector: "Detector",
  workers: "Processing workers", cameras: "Cameras" };
const DOWN_GRACE_S = 3;
// health: the last /health components; cameras: {text, since} while a listed camera has a problem;
// listed: the live status lists cameras (then they, not /health, give the banner's camera line)
const systemState = { health: {}, cameras: null, listed: false };
async function pollHealth() {
  let h = null;
  try { const r = await fetch("/health"); h = await r.json(); } catch (e) { /* the connection pill says it */ }
  systemState.health = (h && h.components) || {}; renderSystem();
}

// The one camera count on the page: the Cameras heading and the system banner both say these words, made
// from the same camera list (the live status), so they never disagree.
function cameraWords(cams) {
  const bad = cams.filter((c) => !c.healthy);
  if (!bad.length) return { ok: true, text: `${cams.length} cameras, all working` };
  const names = bad.map((c) => `${c.name} (${c.status})`).join(", ");
  return { ok: false, text: `${cams.length - bad.length} of ${cams.length} cameras working; not working: ${names}` };
}

function noteCameraProblem(words, listed) {
  systemState.listed = listed;
  const since = systemState.cameras ? systemState.cameras.since : Date.now() / 1000;
  systemState.cameras = words.ok ? null : { text: words.text, since };
  renderSystem();
}

function renderSystem() {
  const now = Date.now() / 1000, items = [];
  for (const [name, c] of Object.entries(systemState.health)) {
    if (c.ok !== false || (name === "cameras" && systemState.listed)) continue;  // from the camera list (below)
    if (c.since && now - c.since < DOWN_GRACE_S) continue;
    items.push(`<li data-component="${esc(name)}"><b>${esc(COMPONENT_NAMES[name] || name)}:</b> ${esc(c.status)}</li>`);
  }
  const cams = systemState.cameras;
  if (cams && now - cams.since >= DOWN_GRACE_S)
    items.push(`<li data-component="cameras"><b>${COMPONENT_NAMES.cameras}:</b> ${esc(cams.text)}</li>`);
  const html = items.join("");  // rewritten only when it changes: the alert is not announced again and again
  if ($("#system-list").innerHTML !== html) $("#system-list").innerHTML = html;
  $("#system").hidden = !items.length;
}

// ---------- formatting ----------
const UNITS = [["_steps_per_min", "steps/min"], ["_per_min", "/min"], ["_m_per_s", "m/s"], ["_mm_per_s", "mm/s"],
  ["_mm", "mm"], ["_pct", "%"], ["_percent", "%"], ["_deg", "°"], ["_s", "s"], ["_m", "m"], ["_hz", "Hz"]];
function nice(name, unit) {
  let text = name, u = unit || "";
  for (const [suffix, label] of UNITS) if (text.endsWith(suffix)) { text = text.slice(0, -suffix.length); u = u || label; break; }
  text = text.replace(/_/g, " ");
  return [text.charAt(0).toUpperCase() + text.slice(1), u];
}
function fmtNum(x) { if (Number.isInteger(x)) return String(x); return Math.abs(x) >= 100 ? x.toFixed(0) : Math.abs(x) >= 10 ? x.toFixed(1) : x.toFixed(2); }
function fmtDuration(s) { const m = Math.floor(s / 60); return `${m}:${String(Math.floor(s % 60)).padStart(2, "0")}`; }
function fmtTime(t) { return t ? new Date(t * 1000).toLocaleString() : ""; }
function esc(s) { return String(s).replace(/[&<>"']/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#39;" }[c])); }

// ---------- boot ----------
$("#start").onclick = startTrial;
$("#stop").onclick = stopTrial;
$("#session").value = new Date().toISOString().slice(0, 10);
$("#login-form").onsubmit = (ev) => {
  ev.preventDefault();
  const password = $("#password-input").value; $("#password-input").value = "";
  signIn($("#user-input").value.trim(), password).catch((e) => showLogin(e.message));
};
$("#logout").onclick = () => { signOut().catch(() => {}); };
setInterval(renderRecording, 1000);
setInterval(pollHealth, 2000); pollHealth();
fetch("/me", { credentials: "same-origin" }).then((r) => (r.ok ? r.json().then(enterApp) : showLogin(""))).catch(() => showLogin(""));
