// Sessions page: a filtered, paged list with delete and import; one session's timeline (commands, what was
// heard with its recording, plans and their revisions, step results with timings, e-stops, falls, errors and
// alarms), its export, and its 3D replay, which follows clicks on the timeline.
"use strict";

const $ = (id) => document.getElementById(id);
const PAGE = 25;
let offset = 0;
let liveSessionId = null;
let current = null; // the session shown below the list
let replayTimer = null;
let lastCameraT = null;

const when = (iso) => (iso ? new Date(iso).toLocaleString() : "–");
const secs = (t) => (t === null || t === undefined ? "–" : `${t.toFixed(2)} s`);
function cell(text) { const td = document.createElement("td"); td.textContent = text; return td; }

function showResult(id, text, ok) {
  const el = $(id);
  el.textContent = text;
  el.className = "result " + (ok ? "ok" : "error");
}

async function errorText(response) {
  try {
    const body = await response.json();
    return typeof body.detail === "string" ? body.detail : JSON.stringify(body.detail);
  } catch (e) {
    return `HTTP ${response.status}`;
  }
}

// ---- the list ------------------------------------------------------------------------------------------------
function filterQuery() {
  const params = new URLSearchParams();
  for (const [key, value] of new FormData($("filters"))) {
    if (!value) continue;
    params.set(key, key === "from" || key === "to" ? new Date(value).toISOString() : value);
  }
  return params;
}

async function loadList() {
  const params = filterQuery();
  params.set("limit", PAGE);
  params.set("offset", offset);
  const r = await fetch(`/api/sessions?${params}`);
  if (!r.ok) { showResult("list-result", await errorText(r), false); return; }
  const data = await r.json();
  liveSessionId = data.live_session_id;
  $("total").textContent = `${data.total}`;
  const body = $("sessions");
  body.innerHTML = "";
  for (const s of data.items) {
    const tr = document.createElement("tr");
    tr.className = "clickable";
    tr.dataset.id = s.id;
    const length = s.ended_at ? Math.round((new Date(s.ended_at) - new Date(s.started_at)) / 1000) + " s" : "running";
    [s.id, s.kind, when(s.started_at), length, s.seed, s.first_command || "–", s.command_count, s.estop_count,
     s.fall_count, s.outcome].forEach((v) => tr.appendChild(cell(String(v))));
    const actions = document.createElement("td");
    const del = document.createElement("button");
    del.textContent = "Delete";
    del.className = "danger";
    del.disabled = s.id === liveSessionId;
    del.title = s.id === liveSessionId ? "the session being recorded now cannot be deleted" : "delete this session";
    del.addEventListener("click", (e) => { e.stopPropagation(); armOrDelete(del, s.id); });
    actions.appendChild(del);
    tr.appendChild(actions);
    tr.addEventListener("click", () => loadDetail(s.id));
    body.appendChild(tr);
  }
  $("prev").disabled = offset === 0;
  $("next").disabled = offset + PAGE >= data.total;
  const pages = Math.max(1, Math.ceil(data.total / PAGE));
  $("page-info").textContent = `page ${Math.floor(offset / PAGE) + 1} of ${pages}`;
}

// Deleting asks twice, in the page: the first click arms the button, the second deletes; a click anywhere else
// disarms it. (A native confirm() would stop the page, its replay included, for as long as it waits.)
function armOrDelete(button, id) {
  if (button.dataset.armed === "yes") return deleteSession(id);
  disarmDeletes();
  button.dataset.armed = "yes";
  button.textContent = "Delete for good?";
  button.title = `click again to delete session ${id} and everything recorded in it (its recordings too): ` +
    "this cannot be undone";
}

function disarmDeletes() {
  for (const button of document.querySelectorAll("#sessions button[data-armed='yes']")) {
    button.dataset.armed = "";
    button.textContent = "Delete";
    button.title = "delete this session";
  }
}
document.addEventListener("click", (e) => {
  if (!(e.target instanceof Element) || !e.target.closest("#sessions button[data-armed='yes']")) disarmDeletes();
});

async function deleteSession(id) {
  const r = await fetch(`/api/sessions/${id}`, { method: "DELETE" });
  if (!r.ok) { showResult("list-result", await errorText(r), false); return; }
  showResult("list-result", `session ${id} deleted`, true);
  if (current && current.id === id) { $("detail").hidden = true; current = null; }
  loadList();
}

async function importFile(file) {
  const r = await fetch("/api/sessions/import", { method: "POST", body: file, headers: { "Content-Type": "application/json" } });
  if (!r.ok) { showResult("list-result", `import failed: ${await errorText(r)}`, false); return; }
  const { session_id } = await r.json();
  showResult("list-result", `imported as session ${session_id}`, true);
  offset = 0;
  await loadList();
  loadDetail(session_id);
}

// ---- one session ---------------------------------------------------------------------------------------------
async function loadDetail(id) {
  const r = await fetch(`/api/sessions/${id}`);
  if (!r.ok) { showResult("list-result", await errorText(r), false); return; }
  const s = await r.json();
  current = s;
  history.replaceState(null, "", `/sessions?id=${id}`);
  $("detail").hidden = false;
  $("detail-title").textContent = `Session ${s.id} (${s.kind}, seed ${s.seed}): ${s.outcome}`;
  $("detail-summary").textContent = `${s.telemetry.samples} samples at ${(s.telemetry.rate_hz || 0).toFixed(0)} Hz over ` +
    `${s.telemetry.duration_s.toFixed(1)} s · ${s.camera_frame_count} camera frames · ${s.command_count} commands · ` +
    `${s.estop_count} e-stops · ${s.fall_count} falls`;
  $("export-json").href = `/api/sessions/${id}/export?format=json`;
  $("export-mcap").href = `/api/sessions/${id}/export?format=mcap`;
  renderTimeline(s);
  renderPlans(s);
  renderEvents(s);
  await startReplay(s);
}

function renderTimeline(s) {
  const list = $("timeline");
  list.innerHTML = s.timeline.length ? "" : '<li class="muted">nothing happened</li>';
  s.timeline.forEach((item, i) => {
    const li = document.createElement("li");
    li.className = `tl tl-${item.type} lvl-${item.level}`;
    li.dataset.index = i;
    li.dataset.t = item.sim_time_s;
    const t = document.createElement("span");
    t.className = "tl-time";
    t.textContent = secs(item.sim_time_s);
    const kind = document.createElement("span");
    kind.className = "tl-kind";
    kind.textContent = item.type;
    const text = document.createElement("span");
    text.textContent = item.text;
    li.append(t, kind, text);
    if (item.audio_url) {
      const audio = document.createElement("audio");
      audio.controls = true;
      audio.preload = "none";
      audio.src = item.audio_url;
      audio.addEventListener("click", (e) => e.stopPropagation());
      li.appendChild(audio);
    }
    if (item.camera_url) {  // what a behaviour noticed: the camera's view at that moment
      const link = document.createElement("a");
      link.href = item.camera_url;
      link.target = "_blank";
      link.textContent = "camera";
      link.className = "tl-camera";
      link.addEventListener("click", (e) => e.stopPropagation());
      li.append(" ", link);
    }
    li.title = "replay from here";
    li.addEventListener("click", () => seekReplay(item.sim_time_s));
    list.appendChild(li);
  });
}

function renderPlans(s) {
  const plans = $("plans");
  plans.innerHTML = s.plans.length ? "" : '<p class="muted">no plans</p>';
  for (const p of s.plans) {
    const div = document.createElement("div");
    const title = document.createElement("p");
    title.textContent = `Plan ${p.plan_id} for "${p.text}" (revision ${p.revision}): ${p.state}`;
    const ol = document.createElement("ol");
    ol.className = "steps";
    for (const st of p.steps) {
      const li = document.createElement("li");
      const args = Object.values(st.args).join(", ");
      const took = st.duration_s !== null && st.duration_s !== undefined ? ` in ${st.duration_s.toFixed(1)} s` : "";
      li.textContent = `${st.action}(${args}): ${st.state}${took}${st.detail ? " (" + st.detail + ")" : ""}`;
      ol.appendChild(li);
    }
    div.append(title, ol);
    plans.appendChild(div);
  }
}

function renderEvents(s) {
  const list = $("events");
  list.innerHTML = "";
  for (const e of s.events) {
    const li = document.createElement("li");
    li.className = "lvl-" + e.level;
    li.textContent = `${when(e.wall_time)} t=${e.sim_time_s.toFixed(2)}s [${e.kind}] ${e.message}`;
    list.appendChild(li);
  }
}

// ---- replay --------------------------------------------------------------------------------------------------
async function startReplay(s) {
  const config = await (await fetch("/api/config")).json();
  const note = $("replay-note");
  const scene = config.replay_port ? await sceneAccess() : null;
  if (!scene || !scene.ports.replay) {
    note.textContent = "The 3D replay is disabled on this server (no 3D views).";
    $("replay-frame").hidden = true;
    return;
  }
  if (!s.telemetry.samples) {
    note.textContent = "This session recorded no motion to replay.";
    return;
  }
  // as the live mirror: on another name of this server the 3D view is another site, so its software WebGL cannot
  // hold up this page; without a GPU it renders at reduced resolution
  const url = scene.url(scene.ports.replay);
  const frame = $("replay-frame");
  if (!frame.src) frame.src = softwareWebGL() ? `${url}?fixedDpr=${config.mirror_software_dpr}` : url;
  note.innerHTML = `3D replay (<a href="${url}" target="_blank" rel="noopener">in its own tab</a>): its panel has the plots (joint target vs position, centre of mass, battery, control tick).`;
  const r = await fetch("/api/replay", { method: "POST", headers: { "Content-Type": "application/json" },
                                         body: JSON.stringify({ session_id: s.id }) });
  if (!r.ok) { note.textContent = `replay: ${await errorText(r)}`; return; }
  showReplay(await r.json());
  if (!replayTimer) replayTimer = setInterval(pollReplay, 250);
}

async function replayCall(path, body) {
  const r = await fetch(`/api/replay${path}`, { method: "POST", headers: { "Content-Type": "application/json" },
                                                  body: JSON.stringify(body || {}) });
  if (r.ok) showReplay(await r.json());
}

function seekReplay(t) {
  if (current && t !== null && t !== undefined) replayCall("/seek", { sim_time_s: t });
}

async function pollReplay() {
  if (!current) return;
  const r = await fetch("/api/replay");
  if (r.ok) showReplay(await r.json());
}

function showReplay(status) {
  if (!current || status.session_id !== current.id) return;
  $("replay-time").textContent = `${status.sim_time_s.toFixed(2)} / ${status.end_s.toFixed(2)} s`;
  $("replay-play").textContent = status.playing ? "Pause" : "Play";
  const seek = $("replay-seek");
  seek.min = status.start_s;
  seek.max = status.end_s;
  if (document.activeElement !== seek) seek.value = status.sim_time_s;
  $("replay-now").textContent = status.now;
  let active = -1;
  current.timeline.forEach((item, i) => { if (item.sim_time_s !== null && item.sim_time_s <= status.sim_time_s + 1e-6) active = i; });
  for (const li of $("timeline").children) li.classList.toggle("tl-active", Number(li.dataset.index) === active);
  if (current.camera_frame_count && (lastCameraT === null || Math.abs(status.sim_time_s - lastCameraT) >= 0.5)) {
    lastCameraT = status.sim_time_s;
    const img = $("replay-camera");
    img.src = `/api/sessions/${current.id}/camera.jpg?t=${status.sim_time_s}`;
    img.hidden = false;
  }
}

$("replay-play").addEventListener("click", () => {
  const playing = $("replay-play").textContent === "Pause";
  replayCall(playing ? "/pause" : "/play", playing ? {} : { speed: Number($("replay-speed").value) });
});
$("replay-speed").addEventListener("change", () => {
  if ($("replay-play").textContent === "Pause") replayCall("/play", { speed: Number($("replay-speed").value) });
});
$("replay-seek").addEventListener("change", () => seekReplay(Number($("replay-seek").value)));

// ---- wiring --------------------------------------------------------------------------------------------------
$("filters").addEventListener("submit", (e) => { e.preventDefault(); offset = 0; loadList(); });
$("f-reset").addEventListener("click", () => { $("filters").reset(); offset = 0; loadList(); });
$("prev").addEventListener("click", () => { offset = Math.max(0, offset - PAGE); loadList(); });
$("next").addEventListener("click", () => { offset += PAGE; loadList(); });
$("import-file").addEventListener("change", (e) => { if (e.target.files.length) importFile(e.target.files[0]); e.target.value = ""; });
loadList().then(() => {
  const wanted = new URLSearchParams(location.search).get("id");
  if (wanted) loadDetail(Number(wanted));
});
