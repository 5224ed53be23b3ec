// gaitcap clinic page: the capture rooms sharing this catalog (GET /rooms), each in its own panel with its
// rig state as that room's API last wrote it (cameras working, the recording there, its latest rig check),
// and the trial list's room filter. Shown only where more than one room is registered. Start and Stop
// always act on this page's own room (its API's cameras and recorder); another room's panel says so.
// Uses api(), esc(), fmtTime(), renderTrials() and state from app.js.
"use strict";

const ROOM_STALE_S = 10;  // a room not seen for longer: its stack (or host) may be down
const OWN_ROOM = "";      // the filter's value for this room's live list (the status WebSocket's)
const roomsState = { rooms: [], filter: OWN_ROOM, timer: null };

const roomLabel = (name) => (name === "" ? "(default)" : name);

// the trial list follows the filter: this room's live list, or the chosen room's trials from GET /trials
function roomFilterActive() { return roomsState.filter !== OWN_ROOM; }

function roomCameras(r) {
  if (!r.cameras_seen) return "no cameras seen";
  const bad = r.cameras.filter((c) => !c.healthy).map((c) => `${esc(c.name)} (${esc(c.status)})`);
  return `${r.cameras_healthy} of ${r.cameras_seen} cameras working` + (bad.length ? `; not working: ${bad.join(", ")}` : "");
}

function roomRigCheck(check) {
  if (!check) return "No rig check yet.";
  if (!check.flagged) return `No camera moved since calibration (trial ${esc(check.trial_id)}).`;
  return `Camera ${check.moved.map(esc).join(", ")} moved since calibration (trial ${esc(check.trial_id)}).`;
}

function roomPanel(r) {
  const stale = r.seen_s_ago > ROOM_STALE_S;
  const seen = stale ? `<p class="error">Not seen for ${Math.round(r.seen_s_ago)} s: its stack or host may be down; `
    + "its trials stay readable here.</p>" : "";
  const where = r.this_room ? "This page's room: Start and Stop act here." : "Start and Stop from that room's page.";
  return `<article class="room-panel${r.this_room ? " room-own" : ""}" data-room="${esc(r.name)}">
    <h3>${esc(roomLabel(r.name))} <small class="muted">${esc(r.host)}</small></h3>${seen}
    <p class="room-recording">${r.recording ? `Recording trial ${esc(r.recording)}` : "Not recording"}</p>
    <p class="room-cameras ${r.cameras_seen && r.cameras_healthy === r.cameras_seen ? "" : "cal-fail"}">${roomCameras(r)}</p>
    <p class="room-rig-check ${r.rig_check && r.rig_check.flagged ? "cal-fail" : "muted"}">${roomRigCheck(r.rig_check)}</p>
    <p class="muted">${where}</p></article>`;
}

function renderRoomFilter() {
  const select = document.querySelector("#trials-room");
  const others = roomsState.rooms.filter((r) => !r.this_room).map((r) => r.name);
  const wanted = [[OWN_ROOM, "This room (live)"], ...others.map((n) => ["room:" + n, roomLabel(n)])];
  const key = JSON.stringify(wanted);
  if (select.dataset.key === key) return;
  select.dataset.key = key;
  select.innerHTML = wanted.map(([v, label]) => `<option value="${esc(v)}">${esc(label)}</option>`).join("");
  select.value = wanted.some(([v]) => v === roomsState.filter) ? roomsState.filter : OWN_ROOM;
  roomsState.filter = select.value;
}

async function loadFilteredTrials() {
  if (!roomFilterActive()) return;
  const asked = roomsState.filter;
  const trials = await api("/trials?room=" + encodeURIComponent(asked.slice("room:".length)) + "&limit=20");
  if (roomsState.filter === asked) renderTrials(trials);
}

async function loadRooms() {
  if (!state.user || document.querySelector("#app").hidden) return;
  let rooms;
  try { rooms = await api("/rooms"); } catch (e) { return; }  // the catalog unreachable: the banner says it
  roomsState.rooms = rooms;
  const several = rooms.length > 1;
  document.querySelector("#rooms-card").hidden = !several;
  document.querySelector("#trials-room-filter").hidden = !several;
  const html = rooms.map(roomPanel).join("");
  const box = document.querySelector("#rooms");
  if (box.dataset.key !== html) { box.dataset.key = html; box.innerHTML = html; }
  if (several) renderRoomFilter();
  loadFilteredTrials().catch(() => {});
}

document.querySelector("#trials-room").onchange = (ev) => {
  roomsState.filter = ev.target.value;
  document.querySelector("#trials tbody").innerHTML = "";
  if (!roomFilterActive()) return;  // the next status snapshot fills this room's list
  loadFilteredTrials().catch((e) => showError(e.message));
};
setInterval(loadRooms, 2000);
