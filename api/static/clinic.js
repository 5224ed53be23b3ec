// gaitcap clinic page, part 2: field checks in plain words, both sides against the norms, the report,
// the patient's history (trend and side-by-side comparison). Uses the helpers of app.js ($, api, esc, fmtTime).
"use strict";

const ID_RE = /^[A-Za-z0-9][A-Za-z0-9_.-]*$/;
const ID_MAX = { "Patient ID": 32, "Session": 64 };  // the server's default rules (a clinic may narrow the patient's)

function idProblem(value, what) {
  // the words a clinician reads instead of a pattern; nothing is cut silently
  const max = ID_MAX[what];
  if (!value) return "";
  if (value.length > max) return `${what}: ${value.length} characters; use at most ${max}.`;
  if (/\s/.test(value)) return `${what}: no spaces. Use letters, digits, '.', '_' or '-' (up to ${max}), e.g. ${what === "Session" ? "visit-1" : "P0042"}.`;
  if (!ID_RE.test(value)) return `${what}: use letters, digits, '.', '_' or '-' (up to ${max}), starting with a letter or digit.`;
  return "";
}

function showFieldError(id, text) {
  const e = $(`#${id}-error`), input = $(`#${id}`);
  e.textContent = text; e.hidden = !text;
  input.setAttribute("aria-invalid", text ? "true" : "false");
}

function checkFields() {
  const subject = idProblem($("#subject").value.trim(), "Patient ID"), session = idProblem($("#session").value.trim(), "Session");
  showFieldError("subject", subject); showFieldError("session", session);
  if (subject) $("#subject").focus(); else if (session) $("#session").focus();
  return !subject && !session;
}

// ---------- both sides against the norms ----------
function resetSides() {
  $("#sides-wrap").hidden = true; $("#results-flags").hidden = true; $("#report-pdf").hidden = true;
  $("#results-problems").hidden = true; $("#norm-summary").hidden = true; $("#results-notes").hidden = true;
  $("#sides-table tbody").innerHTML = "";
  for (const c of charts.splice(0)) c.destroy();
  $("#charts").hidden = true; $("#plot-figure").hidden = false;
  $("#correct-status").textContent = "";
}

function sideBars(left, right) {
  // two bars to the same scale (the numbers are in the row; the bars only show the difference at a glance)
  if (left == null || right == null || Math.max(left, right) <= 0) return "";
  const top = Math.max(left, right), bar = (v, side) => `<span class="bar bar-${side}" style="width: ${(100 * v / top).toFixed(1)}%"></span>`;
  return `<span class="bars" aria-hidden="true">${bar(left, "left")}${bar(right, "right")}</span>`;
}

// a number as the server wrote it (services/reports/shown.py: the page, the print and the PDF round alike)
function shownText(text) { return text == null ? "–" : esc(text); }

async function loadSides(trialId) {
  let r;
  try { r = await api(`/trials/${encodeURIComponent(trialId)}/parameters`); } catch (e) { return; }
  if (state.followed !== trialId) return;
  $("#results-patient").textContent = `Patient ${r.subject_id} · ${fmtTime(r.started_at)} · session ${r.session}`
    + (r.voided ? ` · VOID: ${r.void_reason}` : "");
  markVoidResults(r.voided, r.void_reason);
  const body = $("#sides-table tbody");
  body.innerHTML = r.parameters.map((p) => {
    const s = p.shown, out = !p.in_doubt && !p.unstable && p.z != null && Math.abs(p.z) > 1.96;  // s: the server's texts (one rounding rule)
    const ref = p.name === "gait_speed_m_s" && r.gait_speed_reference;
    const range = s.normal_range ? `${shownText(s.normal_range[0])}–${shownText(s.normal_range[1])}`
      : ref ? `${ref.pct_of_mean.toFixed(0)} % of the age-sex mean (no z-score)` : "no reference";
    const doubt = p.in_doubt ? ` <span class="doubt">(data problem)</span>` : "";
    return `<tr data-parameter="${esc(p.name)}"${p.in_doubt ? ' class="in-doubt"' : ""}><td class="wide name"><abbr title="${esc(p.help)}">${esc(p.label)}</abbr> (${esc(p.unit)})${doubt}</td>
      <td data-label="Left">${shownText(s.left)}</td><td data-label="Right">${shownText(s.right)}</td><td data-label="Mean">${shownText(s.mean)}</td><td data-label="SD">${shownText(s.sd)}</td>
      <td data-label="SI %">${shownText(s.symmetry_index_pct)}</td><td data-label="Normal range"${p.norm_source ? ` title="${esc(p.norm_source)}"` : ""}>${range}</td><td data-label="z" class="${out ? "out" : ""}">${shownText(s.z)}</td>
      <td class="wide">${sideBars(p.left, p.right)}</td></tr>`;
  }).join("");
  keepTableRoles($("#sides-table"));
  $("#sides-note").textContent = "Left and right: means over each side's steady steps. Normal range: mean ± 1.96 SD for the patient's age decade and sex"
    + (r.age == null || !r.sex ? " (record the patient's sex and birth year under Patient history to see it)." : ".");
  $("#sides-wrap").hidden = false;
  const flags = $("#results-flags");
  flags.querySelector("ul").innerHTML = r.flags.map((f) => `<li>${esc(f)}</li>`).join("");
  flags.hidden = !r.flags.length;
  const problems = $("#results-problems");
  problems.querySelector("ul").innerHTML = (r.data_problems || []).map((f) => `<li>${esc(f)}</li>`).join("");
  problems.hidden = !(r.data_problems || []).length;
  renderAnalysisNotes(r);
  $("#norm-summary").textContent = [r.norm_summary, r.gait_speed_reference && r.gait_speed_reference.text].filter(Boolean).join(" ");
  $("#norm-summary").hidden = !$("#norm-summary").textContent;
  fillCorrection(r);
  loadFigures(trialId, r.footprints);
  const link = $("#report-pdf");
  link.href = `/trials/${encodeURIComponent(trialId)}/report.pdf`; link.hidden = false;
}

function renderAnalysisNotes(r) {
  // what the gait analysis says of its own steps (missed contacts, steps left out, turns), as the PDF says it
  const box = $("#results-notes"), plural = (n, one, many) => `${n} ${n === 1 ? one : many}`;
  $("#results-steps-count").textContent = `${plural(r.num_steps, "step", "steps")} in ${plural(r.num_passes, "straight pass", "straight passes")} analysed.`;
  box.querySelector("ul").innerHTML = [...(r.analysis_notes || []), ...(r.withheld || [])].map((n) => `<li>${esc(n)}</li>`).join("");
  box.hidden = false;
}

// ---------- interactive figures (uPlot, served from the package; MIT licence in uplot.LICENSE) ----------
const SIDE_COLOURS = { left: "#1f77b4", right: "#d62728" };
const charts = [];

function atTimes(times, values, events) {
  // a series that is null except at the samples nearest to the event times (drawn as markers only)
  const out = new Array(times.length).fill(null);
  for (const t of events) {
    let i = times.findIndex((x) => x >= t);
    if (i < 0) i = times.length - 1;
    if (i > 0 && t - times[i - 1] < times[i] - t) i -= 1;
    out[i] = values[i];
  }
  return out;
}

function markers(label, stroke, shape) {
  // events as markers only: filled dots (heel strikes, footprints) or open circles (toe offs)
  const fill = shape === "filled" ? stroke : "#fff";
  return { label, stroke, fill, width: 0, paths: () => null, points: { show: true, size: 9, stroke, fill } };
}

async function loadFigures(trialId, footprints) {
  for (const c of charts.splice(0)) c.destroy();
  let f;
  try { f = await api(`/trials/${encodeURIComponent(trialId)}/figures`); } catch (e) { $("#charts").hidden = true; return; }
  if (state.followed !== trialId || typeof uPlot === "undefined") return;
  $("#charts").hidden = false; $("#plot-figure").hidden = true;
  const width = () => Math.max(280, $("#charts").clientWidth - 4);
  const data = [f.times_s], series = [{ label: "time (s)", value: (u, v) => v == null ? "–" : v.toFixed(2) }];
  for (const side of ["left", "right"]) {
    const z = f[`${side}_heel_z_mm`];
    if (!z.length) continue;
    data.push(z); series.push({ label: `${side} heel (mm)`, stroke: SIDE_COLOURS[side], width: 1.5 });
    data.push(atTimes(f.times_s, z, f.events[side].heel_strike_s)); series.push(markers(`${side} heel strike`, SIDE_COLOURS[side], "filled"));
    data.push(atTimes(f.times_s, z, f.events[side].toe_off_s)); series.push(markers(`${side} toe off`, SIDE_COLOURS[side], "open"));
  }
  charts.push(new uPlot({ width: width(), height: 240, scales: { x: { time: false } }, series,
    axes: [{ label: "time (s)" }, { label: "heel height (mm)" }] }, data, $("#heel-chart")));
  const feet = [...footprints].sort((a, b) => a.along_mm - b.along_mm);
  if (feet.length > 1) {
    const x = feet.map((p) => p.along_mm), fd = [x];
    const fs = [{ label: "along (mm)" }];
    for (const side of ["left", "right"]) {
      fd.push(feet.map((p) => (p.side === side ? p.across_mm : null)));
      fs.push(markers(`${side} heel (mm across)`, SIDE_COLOURS[side], "filled"));
    }
    charts.push(new uPlot({ width: width(), height: 180, scales: { x: { time: false } }, series: fs,
      axes: [{ label: "along the walk (mm)" }, { label: "across (mm)" }] }, fd, $("#foot-chart")));
  }
}

new ResizeObserver(() => { for (const c of charts) c.setSize({ width: Math.max(280, $("#charts").clientWidth - 4), height: c.height }); })
  .observe(document.querySelector("#results"));
new ResizeObserver(() => {
  for (const c of trendCharts) { c.setSize({ width: trendWidth(c.root.parentElement), height: c.height }); c.setData(c.data); }  // room for the dates again
})
  .observe(document.querySelector("#patient-card"));

// ---------- the patient's history ----------
async function showHistory(subjectId) {
  const err = $("#patient-error");
  err.hidden = true;
  const problem = idProblem(subjectId, "Patient ID");
  if (problem || !subjectId) { err.textContent = problem || "Enter a patient ID."; err.hidden = false; return; }
  let h;
  try { h = await api(`/patients/${encodeURIComponent(subjectId)}`); } catch (e) {
    if (e.status !== 404) { err.textContent = "Could not load the history: " + e.message; err.hidden = false; return; }
    h = { id: subjectId.toUpperCase(), created_at: null, history: [], sex: "", birth_year: null, notes: "", isNew: true };
  }
  $("#patient-view").hidden = false;
  fillPatientDetails(h);
  const visits = h.history.filter((t) => !t.voided).length;
  $("#patient-summary").textContent = h.isNew ? `New patient ${h.id}: no trials yet. Record the sex and birth year for the normal ranges.`
    : `Patient ${h.id}, first seen ${fmtTime(h.created_at)}; ${h.history.length} trial(s), ${visits} valid`
    + (h.sex ? `; ${h.sex}` : "") + (h.birth_year ? `, born ${h.birth_year}` : "") + (h.notes ? `. Notes: ${h.notes}` : "");
  const body = $("#history-table tbody");
  body.innerHTML = h.history.map((t) => {
    const v = (t.shown || {}).values || {};  // the server's texts (one rounding rule)
    return `<tr data-trial="${esc(t.id)}" class="${t.voided ? "voided" : ""}">
      <td data-label="Compare"><input type="checkbox" class="cmp" value="${esc(t.id)}" aria-label="Compare ${esc(t.session)}" ${t.voided || !t.results.length ? "disabled" : ""}></td>
      <td data-label="Date" class="when">${fmtTime(t.started_at || t.created_at)}</td><td data-label="Session" class="id-cell">${esc(t.session)}</td>
      <td data-label="Gait speed (m/s)">${shownText(v.gait_speed_m_s)}</td><td data-label="Cadence (steps/min)">${shownText(v.cadence_steps_min)}</td>
      <td data-label="Step length (mm)">${shownText(v.step_length_mm)}</td><td data-label="Step length SI (%)">${shownText(v.step_length_symmetry_index_pct)}</td>
      <td data-label="State" class="wide">${esc(t.state_text)}${t.voided ? `<div class="void-note">Void: ${esc(t.void_reason)}</div>` : ""}</td>
      <td class="wide">${t.results.length ? `<a href="/trials/${encodeURIComponent(t.id)}/report.pdf" target="_blank" rel="noopener">Report (PDF)</a>` : ""}</td></tr>`;
  }).join("");
  keepTableRoles($("#history-table"));
  for (const box of body.querySelectorAll(".cmp")) box.onchange = compareChecked;
  drawTrends(h.history);
  $("#compare").hidden = true;
}

// ---------- trends over the visits (uPlot), each with its normal band where the norms have one ----------
const TRENDS = [
  // minSpan: the least y range drawn (so that 1.18 -> 1.19 m/s does not fill the chart like a fall)
  { name: "gait_speed_m_s", label: "Gait speed", unit: "m/s", decimals: 2, minSpan: 0.5 },
  { name: "step_length_mm", label: "Step length", unit: "mm", decimals: 0, minSpan: 200 },
  { name: "cadence_steps_min", label: "Cadence", unit: "steps/min", decimals: 1, minSpan: 30 },
  { name: "step_length_symmetry_index_pct", label: "Step length symmetry index", unit: "%", decimals: 1, fromZero: true },
];
const trendCharts = [];
let trendHistory = [];

function trendWidth(fig) { return Math.max(240, fig.clientWidth - 4); }

// ---------- the visits' date axis: a tick per visit (as many as fit), "24 Nov 2026", with the time of day
// ("24 Nov 2026 14:05") only where two of the drawn visits share a day; the page's local time ----------
const MONTHS = ["Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec"];
const Y_AXIS_PX = 56;
const AXIS_FONT = '12px system-ui, -apple-system, "Segoe UI", Roboto, "Helvetica Neue", Arial, sans-serif';  // uPlot's
const measure = document.createElement("canvas").getContext("2d");

function dayOf(t_s) { const d = new Date(t_s * 1000); return `${d.getFullYear()}-${d.getMonth()}-${d.getDate()}`; }

function visitLabel(t_s, shared) {
  const d = new Date(t_s * 1000), date = `${d.getDate()} ${MONTHS[d.getMonth()]} ${d.getFullYear()}`;
  return shared.has(dayOf(t_s)) ? `${date} ${String(d.getHours()).padStart(2, "0")}:${String(d.getMinutes()).padStart(2, "0")}` : date;
}

function visitAxis(times_s) {
  // the x scale and axis of a trend: ticks at the visits, the newest kept, older ones where their labels fit
  const perDay = new Map();
  for (const t of times_s) perDay.set(dayOf(t), (perDay.get(dayOf(t)) || 0) + 1);
  const shared = new Set([...perDay].filter(([, n]) => n > 1).map(([day]) => day));
  measure.font = AXIS_FONT;
  const labelPx = (t) => measure.measureText(visitLabel(t, shared)).width + 16;  // with a gap (px)
  const range = (u, lo, hi) => {
    // the newest visit's label inside the chart on the right (the axis has ~20 px beyond the plot there),
    // a little room on the left (its label may reach under the y axis); one day around a single visit
    if (!(hi > lo)) return [lo - 86400, hi + 86400];
    const plotPx = u.bbox && u.bbox.width ? u.bbox.width / uPlot.pxRatio : u.width - Y_AXIS_PX - 40;
    const rightPx = Math.max(8, labelPx(hi) / 2 - 20), leftPx = 8, dataPx = Math.max(40, plotPx - rightPx - leftPx);
    return [lo - (hi - lo) * leftPx / dataPx, hi + (hi - lo) * rightPx / dataPx];
  };
  const splits = (u) => {
    const kept = [];
    for (const t of [...new Set(u.data[0])].sort((a, b) => b - a)) {
      const last = kept[kept.length - 1];
      if (last == null || u.valToPos(last, "x") - u.valToPos(t, "x") >= (labelPx(last) + labelPx(t)) / 2) kept.push(t);
    }
    return kept.reverse();
  };
  return { scale: { time: true, range }, axis: { label: "visit date", font: AXIS_FONT, splits, values: (u, ticks) => ticks.map((t) => visitLabel(t, shared)) } };
}

function trendChart(spec, visits, box) {
  // one parameter per visit (line and dots), void visits as grey rings, the normal band per visit's age
  const fmt = (v) => v == null ? "–" : v.toFixed(spec.decimals);
  // a visit's value and band as the server wrote them (the history table's, the PDF's): one rounding rule
  const said = (i) => ((visits[i].shown || {}).values || {})[spec.name];
  const band = visits.map((t) => t.normal_ranges[spec.name] || null);
  const bandSaid = visits.map((t) => ((t.shown || {}).normal_ranges || {})[spec.name] || null);
  const hasBand = band.some((b) => b);
  const data = [visits.map((t) => t.started_at || t.created_at), visits.map((t) => t.values[spec.name] ?? null),
    visits.map((t) => (t.voided ? t.values[spec.name] ?? null : null))];
  const series = [{ label: "date" },
    { label: `${spec.label} (${spec.unit})`, stroke: "#1f3a5f", width: 2, spanGaps: true, value: (u, v, si, i) => (v == null ? "–" : said(i) ?? fmt(v)), points: { show: true, size: 8, fill: "#1f3a5f" } },
    { ...markers("void trial", "#5b6675", "open"), value: (u, v, si, i) => (v == null ? "–" : said(i) ?? fmt(v)) }];
  const dates = visitAxis(data[0]);
  const spanned = (u, lo, hi) => {  // at least minSpan around the data (and the band), centred on them
    const mid = (lo + hi) / 2, half = Math.max(spec.minSpan, 1.1 * (hi - lo)) / 2;
    return [mid - half, mid + half];
  };
  const scales = { x: dates.scale, y: { range: spec.fromZero ? (u, lo, hi) => [0, Math.max(10, 1.2 * (hi ?? 0))] : spanned } };
  const opts = { height: 190, series, scales, legend: { show: false },
    axes: [dates.axis, { label: spec.unit, size: Y_AXIS_PX }] };
  if (hasBand) {
    data.push(band.map((b) => (b ? b[1] : null)), band.map((b) => (b ? b[0] : null)));
    series.push({ label: "normal high", stroke: "#6fbf80", width: 1, dash: [4, 4], value: (u, v) => fmt(v), points: { show: false } },
      { label: "normal low", stroke: "#6fbf80", width: 1, dash: [4, 4], value: (u, v) => fmt(v), points: { show: false } });
    opts.bands = [{ series: [3, 4], fill: "rgba(111, 191, 128, 0.22)" }];
  }
  const fig = document.createElement("figure");
  fig.className = "trend"; fig.dataset.parameter = spec.name;
  const cap = document.createElement("figcaption"), last = bandSaid.filter((b) => b).pop();
  cap.textContent = `${spec.label} (${spec.unit}) per visit, by visit date; ` + (last
    ? `shaded: the normal range for age and sex (at the last visit ${last[0]}–${last[1]} ${spec.unit}).`
    : "no reference range.") + (data[2].some((v) => v != null) ? " Grey rings: void trials." : "");
  fig.append(cap); box.append(fig);
  trendCharts.push(new uPlot({ ...opts, width: trendWidth(fig) }, data, fig));
}

function drawTrends(history) {
  trendHistory = history;
  for (const c of trendCharts.splice(0)) c.destroy();
  const box = $("#trends"), withVoid = $("#trend-void").checked;
  box.innerHTML = "";
  const visits = history.filter((t) => (withVoid || !t.voided) && Object.keys(t.values).length);
  const left = history.filter((t) => t.voided).length;
  $("#trend-note").textContent = left ? (withVoid ? `${left} void trial(s) included.` : `${left} void trial(s) left out.`) : "";
  if (!visits.length) { box.innerHTML = '<p class="muted">No results yet.</p>'; return; }
  if (typeof uPlot === "undefined") return;
  for (const spec of TRENDS) trendChart(spec, visits, box);
}

function signedChange(delta, d) {
  // "+0.02", "-3"; a change that rounds to nothing is "0", never "-0.00" or "+0.00"
  const text = delta.toFixed(d);
  return Number(text) === 0 ? "0" : (delta > 0 ? "+" : "") + text;
}

async function compareChecked() {
  const ids = [...document.querySelectorAll("#history-table .cmp:checked")].map((b) => b.value);
  const box = $("#compare"), note = $("#compare-note");
  note.textContent = ids.length > 2 ? `${ids.length} visits are ticked: tick exactly two to compare them side by side.` : "";
  note.hidden = ids.length <= 2;
  if (ids.length !== 2) { box.hidden = true; return; }
  const [a, b] = (await Promise.all(ids.map((id) => api(`/trials/${encodeURIComponent(id)}/parameters`))))
    .sort((x, y) => x.started_at - y.started_at);  // the earlier visit first: the change is later minus earlier
  // each visit by its date and time of day (two visits on one day stay apart) and its session
  const visit = (r) => `${esc(r.session)}, ${visitLabel(r.started_at, new Set([dayOf(r.started_at)]))}`;
  $("#compare-table thead").innerHTML = `<tr><th rowspan="2">Parameter</th><th colspan="3" scope="colgroup" class="visit">${visit(a)}</th>
    <th colspan="3" scope="colgroup" class="visit">${visit(b)}</th><th colspan="3" scope="colgroup">Change</th></tr>
    <tr>${"<th>L</th><th>R</th><th>Mean</th>".repeat(3)}</tr>`;
  $("#compare-table tbody").innerHTML = a.parameters.map((p, i) => {
    const q = b.parameters[i], d = p.decimals, ps = p.shown, qs = q.shown;
    // the change of the numbers shown beside it (the server's rounded texts), never of the unrounded values
    const change = (x, y) => (x != null && y != null ? signedChange(Number(y) - Number(x), d) : "–");
    return `<tr data-parameter="${esc(p.name)}"><td>${esc(p.label)} (${esc(p.unit)})</td><td>${shownText(ps.left)}</td><td>${shownText(ps.right)}</td><td>${shownText(ps.mean)}</td>
      <td>${shownText(qs.left)}</td><td>${shownText(qs.right)}</td><td>${shownText(qs.mean)}</td>
      <td>${change(ps.left, qs.left)}</td><td>${change(ps.right, qs.right)}</td><td>${change(ps.mean, qs.mean)}</td></tr>`;
  }).join("");
  box.hidden = false;
}

// ---------- clinical fields, corrections, void marks (all audited by the server) ----------
const FIELD_INPUTS = { walking_aid: "walking-aid", assistance: "assistance", footwear: "footwear", notes: "trial-notes" };
const FIX_INPUTS = { walking_aid: "fix-aid", assistance: "fix-assistance", footwear: "fix-footwear", notes: "fix-notes" };

function saveClinicalFields(trialId) {
  const body = { operator: state.user || "", reason: "entered at Start" };
  for (const [key, id] of Object.entries(FIELD_INPUTS)) { const v = $(`#${id}`).value.trim(); if (v) body[key] = v; }
  api(`/trials/${encodeURIComponent(trialId)}/correct`, { method: "POST", body })
    .catch((e) => showError("The recording runs, but walking aid, footwear and notes were not saved: " + e.message));
}

function fillCorrection(r) {
  // a results update while the clinician types a correction keeps what they typed (same trial, edited)
  const box = $("#correct-box");
  box.hidden = !$("#record") || $("#record").hidden;  // correcting needs the recording permission
  const editing = box.dataset.trial === r.trial_id && box.dataset.edited === "yes";
  box.dataset.trial = r.trial_id;
  if (!editing) {
    box.dataset.edited = "no";
    $("#fix-subject").value = r.subject_id; $("#fix-session").value = r.session; $("#fix-reason").value = "";
    for (const [key, id] of Object.entries(FIX_INPUTS)) $(`#${id}`).value = r.details[key] || "";
  }
  $("#void-button").disabled = r.voided;
  if (r.voided) $("#correct-status").textContent = `This trial is void: ${r.void_reason}`;  // else keep "Saved: ..."
}

async function submitCorrection(ev) {
  ev.preventDefault();
  const trialId = $("#correct-box").dataset.trial, status = $("#correct-status");
  const subject = $("#fix-subject").value.trim(), session = $("#fix-session").value.trim();
  const problem = idProblem(subject, "Patient ID") || idProblem(session, "Session");
  if (problem) { status.textContent = problem; return; }
  if (!$("#fix-reason").value.trim()) {
    status.textContent = "Not saved: give the reason for the change (it is kept in the audit log).";
    $("#fix-reason").setAttribute("aria-invalid", "true"); $("#fix-reason").focus(); return;
  }
  $("#fix-reason").setAttribute("aria-invalid", "false");
  const body = { subject_id: subject, session, reason: $("#fix-reason").value.trim() };
  for (const [key, id] of Object.entries(FIX_INPUTS)) body[key] = $(`#${id}`).value.trim();
  try {
    const r = await api(`/trials/${encodeURIComponent(trialId)}/correct`, { method: "POST", body });
    $("#correct-box").dataset.edited = "no";  // saved: the next update shows what the server holds
    const changed = Object.keys(r.changed);
    status.textContent = changed.length ? `Saved: ${changed.join(", ").replace(/_/g, " ")} changed.` : "Nothing was changed.";
    if (changed.length) loadSides(trialId);
  } catch (e) { status.textContent = "Not saved: " + e.message; }
}

async function markVoid() {
  const trialId = $("#correct-box").dataset.trial, status = $("#correct-status");
  const reason = (prompt("Why is this trial void? At least 5 characters; kept with the trial and in the audit log.") || "").trim();
  if (!reason) return;
  if (reason.length < 5) { status.textContent = "Not marked void: the reason needs at least 5 characters."; return; }
  try {
    await api(`/trials/${encodeURIComponent(trialId)}/mark-void`, { method: "POST", body: { reason } });
    loadSides(trialId);
  } catch (e) { status.textContent = "Not marked void: " + e.message; }
}

$("#correct-form").onsubmit = submitCorrection;
$("#correct-form").addEventListener("input", () => { $("#correct-box").dataset.edited = "yes"; });
$("#void-button").onclick = markVoid;
function fillPatientDetails(h) {
  const form = $("#patient-details");
  form.dataset.patient = h.id;
  $("#patient-sex").value = h.sex || ""; $("#patient-birth-year").value = h.birth_year || "";
  $("#patient-details-status").textContent = "";
  $("#patient-birth-year").setAttribute("aria-invalid", "false");
}

function birthYearProblem(text) {
  const year = new Date().getFullYear();
  if (!text) return "";
  if (!/^[0-9]{4}$/.test(text)) return "Birth year: four digits, e.g. 1952.";
  const y = Number(text);
  return y < year - 120 || y > year ? `Birth year: between ${year - 120} and ${year}.` : "";
}

async function savePatientDetails(ev) {
  ev.preventDefault();
  const id = $("#patient-details").dataset.patient, status = $("#patient-details-status");
  const text = $("#patient-birth-year").value.trim(), problem = birthYearProblem(text);
  $("#patient-birth-year").setAttribute("aria-invalid", problem ? "true" : "false");
  if (problem) { status.textContent = "Not saved: " + problem; $("#patient-birth-year").focus(); return; }
  const body = { sex: $("#patient-sex").value };
  if (text) body.birth_year = Number(text);
  try {
    const p = await api(`/patients/${encodeURIComponent(id)}`, { method: "PUT", body });
    status.textContent = `Saved (audited): ${p.sex || "sex not recorded"}${p.birth_year ? `, born ${p.birth_year}` : ""}. The normal ranges use them now.`;
    if (state.followed) loadSides(state.followed);
    await showHistory(id);
    status.textContent = `Saved (audited): ${p.sex || "sex not recorded"}${p.birth_year ? `, born ${p.birth_year}` : ""}. The normal ranges use them now.`;
  } catch (e) { status.textContent = "Not saved: " + e.message; }
}

$("#patient-details").onsubmit = savePatientDetails;
$("#patient-form").onsubmit = (ev) => { ev.preventDefault(); showHistory($("#patient-input").value.trim()); };
$("#print").onclick = () => window.print();
$("#trend-void").onchange = () => drawTrends(trendHistory);
for (const id of ["subject", "session"]) {
  $(`#${id}`).addEventListener("input", () => showFieldError(id, idProblem($(`#${id}`).value.trim(), id === "subject" ? "Patient ID" : "Session")));
}
