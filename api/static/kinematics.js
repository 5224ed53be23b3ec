// gaitcap clinic page, part 3: joint angles over the gait cycle (mean ± SD per side over the normal band)
// and their key values, from GET /trials/{id}/kinematics. Uses app.js's helpers ($, api, esc, state) and
// uPlot (vendored, MIT). The angles arrive after the gait result: the box waits for them.
"use strict";

const KIN_LABELS = {
  pelvis_tilt: "Pelvic tilt (anterior +)", pelvis_obliquity: "Pelvic obliquity (up +)",
  pelvis_rotation: "Pelvic rotation (forward +)", hip_flexion: "Hip flexion / extension",
  hip_adduction: "Hip adduction / abduction", hip_rotation: "Hip rotation (internal +)",
  knee_flexion: "Knee flexion / extension", ankle_dorsiflexion: "Ankle dorsi- / plantarflexion",
  trunk_flexion: "Trunk flexion relative to the pelvis",
};
const KIN_SIDES = { left: "#1f77b4", right: "#d62728" };
const kinCharts = [];
let kinTimer = null;

function kinBox() { return $("#kinematics"); }

function kinReset(text) {
  clearTimeout(kinTimer); kinTimer = null;
  for (const c of kinCharts.splice(0)) c.destroy();
  const box = kinBox();
  if (!box) return;
  box.hidden = !text;
  $("#kinematics-status").textContent = text || "";
  $("#kinematics-charts").innerHTML = ""; $("#kinematics-keys").innerHTML = ""; $("#kinematics-notes").innerHTML = "";
}

async function loadKinematics(trialId, stage, tries = 120) {
  // tries: how many more times to ask (every 5 s) while the angles are still being computed
  if (!kinBox()) return;
  if (tries === 120) kinReset("Joint angles: waiting for the model fit…");
  let k;
  try { k = await api(`/trials/${encodeURIComponent(trialId)}/kinematics?stage=${stage}`); } catch (e) {
    if (state.followed !== trialId) return;
    if (e.status === 404 && /not computed/.test(e.message) && tries > 0) {
      kinTimer = setTimeout(() => loadKinematics(trialId, stage, tries - 1), 5000); return;
    }
    kinReset("Kinematics unavailable: " + e.message); return;
  }
  if (state.followed !== trialId) return;
  if (!k.available) { kinReset("Kinematics unavailable: " + (k.reason || "no reason given")); return; }
  kinReset("Joint angles over the gait cycle (degrees; 0 % and 100 %: heel strikes of the same foot).");
  drawKinematics(k);
}

function kinSeries(mean, sd) {
  const lo = mean.map((m, i) => (m == null || sd[i] == null ? null : m - sd[i]));
  const hi = mean.map((m, i) => (m == null || sd[i] == null ? null : m + sd[i]));
  return [lo, hi];
}

function kinChart(k, name, side, el) {
  // one panel: the normal band (grey, mean ± 1 SD), this side's mean ± SD over its cycles
  // a band is drawn only where the table compares the angle's values with it (not norms.not_drawn)
  const undrawn = (k.norms.not_drawn || {})[name], band = undrawn ? null : k.norms.bands[name];
  const c = k.curves[name][side], data = [k.percent], series = [{ label: "% cycle" }], bands = [];
  el.dataset.band = band ? "drawn" : "none";
  if (band) {
    const [lo, hi] = kinSeries(band.mean_deg, band.sd_deg);
    data.push(hi, lo);
    series.push({ label: "normal +1 SD", stroke: "#b8bec7", width: 1 }, { label: "normal −1 SD", stroke: "#b8bec7", width: 1 });
    bands.push({ series: [1, 2], fill: "rgba(150,150,150,0.25)" });
  }
  if (c.n_cycles) {
    const [lo, hi] = kinSeries(c.mean_deg, c.sd_deg), first = data.length;
    data.push(hi, lo, c.mean_deg);
    series.push({ label: "+1 SD", stroke: KIN_SIDES[side], width: 0.5, dash: [3, 3] }, { label: "−1 SD", stroke: KIN_SIDES[side], width: 0.5, dash: [3, 3] },
      { label: `${side} mean (deg)`, stroke: KIN_SIDES[side], width: 2 });
    bands.push({ series: [first, first + 1], fill: side === "left" ? "rgba(31,119,180,0.15)" : "rgba(214,39,40,0.15)" });
  }
  const width = Math.max(240, el.clientWidth - 4);
  kinCharts.push(new uPlot({ width, height: 170, scales: { x: { time: false, range: [0, 100] } }, series, bands,
    legend: { show: false }, axes: [{ label: "% gait cycle", size: 30 }, { label: "deg", size: 40 }] }, data, el));
}

function drawKinematics(k) {
  const grid = $("#kinematics-charts");
  for (const name of Object.keys(k.curves)) {
    for (const side of ["left", "right"]) {
      const c = k.curves[name][side], fig = document.createElement("figure");
      fig.className = "kin-panel"; fig.dataset.variable = name; fig.dataset.side = side;
      fig.innerHTML = `<figcaption>${esc(KIN_LABELS[name] || name)}, ${side} (${c.n_cycles} cycle${c.n_cycles === 1 ? "" : "s"})</figcaption>`;
      grid.appendChild(fig);
      if (c.n_cycles && typeof uPlot !== "undefined") kinChart(k, name, side, fig);
      else fig.insertAdjacentHTML("beforeend", '<p class="muted">No complete gait cycle on this side.</p>');
    }
  }
  const notes = [];
  const n = k.norms || {};
  notes.push(n.no_reference ? `No normal band: ${n.no_reference}.`
    : n.source ? `Grey band: normal mean ± 1 SD for ${n.population}. Source: ${n.source}.`
    : "No normal band: no normative data is installed.");
  if (!n.no_reference) for (const [name, why] of Object.entries(n.missing || {})) if (k.curves[name]) notes.push(`${KIN_LABELS[name] || name}: no band (${why}).`);
  for (const [name, why] of Object.entries(n.not_drawn || {})) if (k.curves[name]) notes.push(`${KIN_LABELS[name] || name}: ${why}.`);
  for (const [name, why] of Object.entries(k.not_measured || {})) notes.push(`${KIN_LABELS[name] || name}: not measured (${why}).`);
  for (const w of k.warnings || []) notes.push(`Warning: ${w}.`);
  $("#kinematics-notes").innerHTML = notes.map((t) => `<li>${esc(t)}</li>`).join("");
  const kv = k.key_values || {}, keys = Object.keys(kv.left || {}).filter((name) => ["left", "right"].some((s) => ((kv[s] || {})[name] || {}).n));
  const norms = k.key_value_norms || {};
  // the server's texts and verdicts (services/reports/shown.py: the page and the PDF round and mark alike)
  const said = k.key_values_shown || {};
  const cell = (s, side, name) => {
    const t = (said[side] || {})[name] || {};
    return s && t.mean != null ? `${esc(t.mean)}${t.sd != null ? " ± " + esc(t.sd) : ""} (n=${s.n})`
      + (t.outside ? ' <strong class="out-flag">outside</strong>' : "") : "–";
  };
  const range = (nr) => { const t = (nr && nr.shown) || {};
    return !nr ? "no band" : nr.no_reference ? nr.no_reference : t.normal_range ? `${esc(t.normal_range[0])}–${esc(t.normal_range[1])}`
      : t.lower_limit != null ? `at least ${esc(t.lower_limit)} (band's range ${esc(t.normal)})` : "no band"; };
  $("#kinematics-keys").innerHTML = keys.length ? `<caption>Key values (degrees, mean ± SD over the cycles) against the band</caption>
    <thead><tr><th>Key value</th><th>Left</th><th>Right</th><th>Normal (95 %)</th></tr></thead><tbody>${keys.map((name) =>
      `<tr data-key="${esc(name)}"><td>${esc((norms[name] || {}).label || name.replace(/_deg$/, "").replace(/_/g, " "))}</td>
        <td>${cell(k.key_values.left[name], "left", name)}</td><td>${cell(k.key_values.right[name], "right", name)}</td>
        <td>${range(norms[name])}</td></tr>`).join("")}</tbody>` : "";
}

new ResizeObserver(() => {
  for (const c of kinCharts) c.setSize({ width: Math.max(240, c.root.parentElement.clientWidth - 4), height: c.height });
}).observe(document.querySelector("#results"));
