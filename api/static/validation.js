// The trial's agreement with the lab's reference recording (gaitcap validate's result, written into the
// trial's validation/ folder), from GET /trials/{id}/validation: hidden when the trial has none. Uses
// app.js's helpers ($, api, esc, state, withToken).
"use strict";

async function loadValidation(trialId) {
  const box = $("#validation");
  if (!box) return;
  box.hidden = true;
  let v;
  try { v = await api(`/trials/${encodeURIComponent(trialId)}/validation`); } catch (e) { return; }
  if (state.followed !== trialId) return;
  // every text as the server shows it (services/validation/shown_rows.py): the trial report prints the same rows
  const shownV = v.shown || { alignment: "", rows: [], not_compared: [] };
  $("#validation-status").textContent = `${shownV.alignment} ${v.icc_form || ""}`;
  const rows = shownV.rows.map((r) => `<tr><td>${esc(r.what)}</td><td>${r.n}</td><td>${esc(r.difference)}</td>`
    + `<td>${esc(r.agreement)}</td></tr>`);
  $("#validation-table").innerHTML = `<thead><tr><th>what</th><th>n</th><th>gaitcap − reference</th><th></th></tr></thead>`
    + `<tbody>${rows.join("")}</tbody>`;
  $("#validation-notes").innerHTML = shownV.not_compared.map((t) => `<li>${esc(t)}</li>`).join("");
  $("#validation-links").innerHTML = `<a href="${withToken(`/trials/${encodeURIComponent(trialId)}/validation/pdf`)}" download>`
    + `Validation report (PDF)</a>`;
  box.hidden = false;
}
