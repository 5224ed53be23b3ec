// The trial's agreement with the lab's reference recording (gaitcap validate's result, written into the
// trial's validation/ folder), from GET /trials/{id}/validation: hidden when the trial has none. Uses
// app.js's helpers ($, api, esc, state, withToken).
"use strict";

function valFmt(x, d) { return x == null ? "–" : Number(x).toFixed(d); }

async function loadValidation(trialId) {
  const box = $("#validation");
  if (!box) return;
  box.hidden = true;
  let v;
  try { v = await api(`/trials/${encodeURIComponent(trialId)}/validation`); } catch (e) { return; }
  if (state.followed !== trialId) return;
  const a = v.alignment || {};
  $("#validation-status").textContent = `Against ${v.reference_kind || "reference"} ${String(v.reference || "").split("/").pop()}:`
    + ` lag ${valFmt(a.lag_s, 3)} s, residual ${valFmt(a.residual_mm, 1)} mm. ${v.icc_form || ""}`;
  const rows = [];
  for (const e of v.events || []) {
    rows.push(`<tr><td>${esc(e.side)} ${esc(e.kind.replace("_", " "))}</td><td>${e.n}</td>`
      + `<td>${valFmt(e.signed_median_ms, 0)} ms (${valFmt(e.signed_median_frames, 2)} frames)</td>`
      + `<td>missed ${e.missed}, extra ${e.extra}</td></tr>`);
  }
  for (const [name, sides] of Object.entries(v.parameters || {})) {
    const s = sides.all;
    rows.push(`<tr><td>${esc(name)}</td><td>${s.n}</td><td>bias ${valFmt(s.bias, 2)} (LoA ${valFmt(s.loa_low, 2)} to `
      + `${valFmt(s.loa_high, 2)})</td><td>ICC ${valFmt(s.icc, 2)}</td></tr>`);
  }
  for (const x of v.angles || []) {
    rows.push(`<tr><td>${esc(x.side)} ${esc(x.variable)}</td><td>${x.n}</td><td>RMSE ${valFmt(x.rmse_deg, 1)}°, `
      + `offset ${valFmt(x.offset_deg, 1)}°, after offset ${valFmt(x.rmse_after_offset_deg, 1)}°</td><td>r ${valFmt(x.r, 3)}</td></tr>`);
  }
  $("#validation-table").innerHTML = `<thead><tr><th>what</th><th>n</th><th>gaitcap − reference</th><th></th></tr></thead>`
    + `<tbody>${rows.join("")}</tbody>`;
  $("#validation-notes").innerHTML = (v.not_compared || []).map((t) => `<li>Not compared: ${esc(t)}</li>`).join("");
  $("#validation-links").innerHTML = `<a href="${withToken(`/trials/${encodeURIComponent(trialId)}/validation/pdf`)}" download>`
    + `Validation report (PDF)</a>`;
  box.hidden = false;
}
