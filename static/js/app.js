// Mission-control page: state and events over one WebSocket; the e-stop goes over that socket first
// (HTTP as a fallback) and is bound to pointerdown, so nothing waits for a click to complete.
"use strict";

const $ = (id) => document.getElementById(id);
// The state comes 20 times a second: a text or class written unchanged still costs this page a style, layout and
// paint pass, and the browser a composite, CPU that the e-stop's path competes for on a small machine.
function setText(id, text) { const el = $(id); if (el.textContent !== text) el.textContent = text; }
function setClass(id, cls) { const el = $(id); if (el.className !== cls) el.className = cls; }
function setHidden(id, hidden) { const el = $(id); if (el.hidden !== hidden) el.hidden = hidden; }
const humanoid = { setText, setClass, setHidden, ws: null, state: null, estopLatencies: [], estopParts: [], estopWaits: [], events: [], config: null,
                   planSources: {} };
window.humanoid = humanoid;

async function loadConfig() {
  const response = await fetch("/api/config");
  humanoid.config = await response.json();
  $("planner").textContent = "planner: " + humanoid.config.planner;
  const robotAudio = [humanoid.config.microphone, humanoid.config.speaker].filter(Boolean);
  $("robot-audio").textContent = robotAudio.join(" · ");
  $("spoken-stop").textContent = humanoid.config.spoken_stop
    ? "spoken stop on: say \u201cstop\u201d, \u201chalt\u201d or \u201cfreeze\u201d to latch the e-stop"
    : "spoken stop off";
  $("approve-toggle").checked = humanoid.config.approval_required;
  const software = softwareWebGL();
  // Browsers without a GPU get the light view: the full one keeps a CPU renderer busy ~200 ms a frame.
  const profile = software ? "light" : "full";
  const frame = $("scene");
  const scene = await sceneAccess();
  const port = scene && scene.ports[profile];
  if (!port) {
    $("scene-note").textContent = "The 3D mirror is disabled on this server.";
    frame.hidden = true;
    return;
  }
  const url = scene.url(port);
  const fullUrl = scene.url(scene.ports.full);
  frame.src = software ? `${url}?fixedDpr=${humanoid.config.mirror_software_dpr}` : url;
  $("scene-note").innerHTML = scene.crossSite
    ? `3D mirror from <a href="${url}" target="_blank" rel="noopener">another site of this server</a> (it cannot slow the e-stop)` +
      (software
        ? `; software WebGL detected: light view at ${humanoid.config.mirror_software_dpr}x resolution ` +
          `(<a href="${fullUrl}" target="_blank" rel="noopener">full view</a>).`
        : ".")
    : `This browser cannot reach the server by a second name, so the 3D view shares this page's process and may ` +
      `slow the e-stop: open the <a href="${url}" target="_blank" rel="noopener">3D view in its own tab</a>.`;
}

// ---- WebSocket -----------------------------------------------------------------------------------------------
const HEARTBEAT_MS = 250;
const PING_MS = 2000;
const POOR_RTT_MS = 150; // beyond this round trip, the e-stop and teleop feel late: said in the badge
const wsUrl = (path) => `${location.protocol === "https:" ? "wss" : "ws"}://${location.host}${path}`;
function connect() {
  const ws = new WebSocket(wsUrl("/ws"));
  humanoid.ws = ws;
  ws.onopen = () => {
    setConn("connected", "badge-ok");
    // The deadman: on the real robot, torque stays on only while an operator page says it is there.
    const beat = () => ws.readyState === WebSocket.OPEN && ws.send('{"type":"heartbeat"}');
    beat();
    ws.heartbeat = setInterval(beat, HEARTBEAT_MS);
    // The link's round trip, shown with the connection (a pong overdue counts as that slow).
    const ping = () => {
      if (ws.readyState !== WebSocket.OPEN) return;
      if (ws.pingSent !== undefined) linkQuality(performance.now() - ws.pingSent);
      ws.pingSent = performance.now();
      ws.send(JSON.stringify({ type: "ping", t: ws.pingSent }));
    };
    ping();
    ws.pinger = setInterval(ping, PING_MS);
  };
  ws.onclose = () => {
    clearInterval(ws.heartbeat);
    clearInterval(ws.pinger);
    setConn("disconnected: retrying", "badge-err");
    setTimeout(connect, 1000);
  };
  ws.onmessage = (msg) => {
    const m = JSON.parse(msg.data);
    if (m.type === "state") receiveState(m.state);
    else if (m.type === "event") addEvent(m.event);
    else if (m.type === "hello") {
      $("events").innerHTML = "";
      humanoid.connectedAt = null;
      m.recent_events.forEach(addEvent);
      humanoid.connectedAt = Date.now() / 1000 - 1;
    }
    else if (m.type === "estop_release_ack" && !m.accepted) showResult(m.message, true);
    else if (m.type === "teleop_ack" && humanoid.onTeleopAck) humanoid.onTeleopAck(m);
    else if (m.type === "diagnostics" && humanoid.onDiagnostics) humanoid.onDiagnostics(m.diagnostics);
    else if (m.type === "control" && humanoid.onControl) humanoid.onControl(m.control);
    else if (m.type === "pong" && m.t === ws.pingSent) { linkQuality(performance.now() - m.t); ws.pingSent = undefined; }
  };
}

// The e-stop's second path: a socket of its own (its own TCP connection), so that a segment lost on one
// connection, which waits ~200 ms for its resend, does not hold up the stop.
function connectStop() {
  const ws = new WebSocket(wsUrl("/ws/stop"));
  humanoid.stopWs = ws;
  ws.onclose = () => setTimeout(connectStop, 1000);
}

function linkQuality(rttMs) {
  humanoid.rttMs = rttMs;
  const poor = rttMs > POOR_RTT_MS;
  setConn(`connected · ${Math.round(rttMs)} ms` + (poor ? ": slow link, the e-stop and teleop lag" : ""),
          poor ? "badge-warn" : "badge-ok");
}

function setConn(text, cls) { const el = $("conn"); el.textContent = text; el.className = "badge " + cls; }

// ---- e-stop --------------------------------------------------------------------------------------------------
function pressEStop(ev) {
  // The event's own timestamp: latency is measured from the moment the browser saw the press.
  const clientTime = (performance.timeOrigin + (ev && ev.timeStamp ? ev.timeStamp : performance.now())) / 1000;
  if (ev && ev.timeStamp) humanoid.estopWaits.push(performance.now() - ev.timeStamp); // the press waited in the page
  const message = JSON.stringify({ type: "estop", client_time_s: clientTime });
  let sent = 0;
  for (const ws of [humanoid.ws, humanoid.stopWs]) {
    if (ws && ws.readyState === WebSocket.OPEN) { ws.send(message); sent += 1; }
  }
  if (sent < 2) { // a socket is down: HTTP as well
    fetch("/api/estop", { method: "POST", headers: { "Content-Type": "application/json" },
      body: JSON.stringify({ source: "browser", client_time_s: clientTime }) });
  }
}

async function releaseEStop() {
  const r = await fetch("/api/estop/reset", { method: "POST" });
  const body = await r.json();
  showResult(r.ok ? body.message : (body.detail.message || JSON.stringify(body.detail)), !r.ok);
}

$("estop").addEventListener("pointerdown", pressEStop);
$("estop").addEventListener("keydown", (ev) => { if (ev.key === "Enter") pressEStop(ev); });
document.addEventListener("keydown", (ev) => {
  if (ev.key === "Escape" || (ev.key === " " && document.activeElement.tagName !== "INPUT")) {
    ev.preventDefault(); pressEStop(ev);
  }
});
$("release").addEventListener("click", releaseEStop);

// ---- commands ------------------------------------------------------------------------------------------------
humanoid.showResult = (text, isError) => showResult(text, isError);
function showResult(text, isError) {
  const el = $("command-result");
  el.textContent = text;
  el.className = "result " + (isError ? "error" : "ok");
}
// Two readings were close: the planner asks instead of acting. The answer is typed next ("the red mug").
function showQuestion(question) {
  const el = $("command-result");
  el.textContent = question;
  el.className = "result question";
  $("command-text").focus();
}

function describeError(detail) {
  if (typeof detail === "string") return detail;
  if (Array.isArray(detail)) return detail.map((d) => d.msg).join("; ");
  const errors = detail.errors && detail.errors.length ? ": " + detail.errors.join("; ") : "";
  return (detail.message || "refused") + (errors && !errors.includes(detail.message) ? errors : "");
}

async function post(url, body) {
  const r = await fetch(url, { method: "POST", headers: { "Content-Type": "application/json" },
    body: body ? JSON.stringify(body) : undefined });
  const data = await r.json().catch(() => ({ detail: r.statusText }));
  return { ok: r.ok, data };
}

$("command-form").addEventListener("submit", async (ev) => {
  ev.preventDefault();
  const text = $("command-text").value.trim();
  if (!text) return showResult("type a command first", true);
  const heardAs = humanoid.heardAs;
  humanoid.heardAs = null;
  const spoken = heardAs && heardAs.text === text;  // sent as heard, not edited
  const body = spoken ? { text, source: "spoken", alternatives: heardAs.alternatives } : { text, source: "typed" };
  const { ok, data } = await post("/api/commands", body);
  if (!ok && data.detail && data.detail.clarify) return showQuestion(data.detail.clarify);
  showResult(ok ? `accepted: ${data.message}` : describeError(data.detail), !ok);
});
$("replan").addEventListener("click", async () => {
  const { ok, data } = await post("/api/replan");
  showResult(ok ? `replanned: ${data.message}` : describeError(data.detail), !ok);
});
$("cancel").addEventListener("click", async () => {
  const { data } = await post("/api/plan/cancel");
  showResult(data.message, false);
});
$("pause").addEventListener("click", async () => {
  const paused = humanoid.state && humanoid.state.plan && humanoid.state.plan.state === "paused";
  const { ok, data } = await post(paused ? "/api/plan/resume" : "/api/plan/pause");
  showResult(ok ? data.message : describeError(data.detail), !ok);
});
$("approve-toggle").addEventListener("change", async (ev) => {
  const r = await fetch("/api/plan/approval", { method: "PUT", headers: { "Content-Type": "application/json" },
    body: JSON.stringify({ required: ev.target.checked }) });
  const data = await r.json();
  showResult(r.ok ? data.message : describeError(data.detail), !r.ok);
});
$("approve").addEventListener("click", async () => {
  const plan = humanoid.state && humanoid.state.plan;
  const { ok, data } = await post("/api/plan/approve", plan ? { plan_id: plan.plan_id } : null);
  showResult(ok ? data.message : describeError(data.detail), !ok);
});
$("reject").addEventListener("click", async () => {
  const { data } = await post("/api/plan/cancel");
  showResult(data.message === "plan cancelled" ? "plan rejected" : data.message, false);
});
// The plan as the seed's list of flat actions: what an operator reads and writes most easily.
function seedList(plan) { return plan.steps.map((s) => ({ action: s.action, ...s.args })); }
$("edit").addEventListener("click", () => {
  const plan = humanoid.state && humanoid.state.plan;
  if (!plan) return;
  $("plan-json").value = JSON.stringify(seedList(plan), null, 1);
  $("editor").hidden = false;
});
$("close-editor").addEventListener("click", () => { $("editor").hidden = true; });
$("run-edited").addEventListener("click", async () => {
  const plan = humanoid.state && humanoid.state.plan;
  let edited;
  try { edited = JSON.parse($("plan-json").value); } catch (e) { return showResult("not JSON: " + e.message, true); }
  const { ok, data } = await post("/api/commands", { plan: edited, command_id: plan ? plan.command_id : null,
    source: "edited" });
  showResult(ok ? `edited plan: ${data.message}` : describeError(data.detail), !ok);
  if (ok) $("editor").hidden = true;
});

// ---- rendering -----------------------------------------------------------------------------------------------
const fmt = (v, d = 2) => (v === null || v === undefined ? "–" : Number(v).toFixed(d));

// The state arrives 20 times a second; the page shows it at most 10 times a second (a new mode or e-stop at once):
// each showing is a layout, a paint and a composite, and the e-stop's press waits behind them on this thread.
const STATE_SHOWN_EVERY_MS = 100;
let stateTimer = null, shownAt = 0, shown = null;
function receiveState(s) {
  humanoid.state = s;
  const news = !shown || s.estop_latched !== shown.estop_latched || s.mode !== shown.mode || s.fallen !== shown.fallen;
  const wait = STATE_SHOWN_EVERY_MS - (performance.now() - shownAt);
  if (news || wait <= 0) { clearTimeout(stateTimer); stateTimer = null; renderState(s); }
  else if (!stateTimer) stateTimer = setTimeout(() => { stateTimer = null; renderState(humanoid.state); }, wait);
}

function renderState(s) {
  shown = s;
  shownAt = performance.now();
  const latched = s.estop_latched;
  setText("mode", "mode: " + s.mode);
  setClass("mode", "badge " + (latched || s.fallen ? "badge-err" : ["executing", "teleop"].includes(s.mode) ? "badge-warn" : "badge-ok"));
  setHidden("latched-banner", !latched);
  setHidden("release", !latched);
  $("estop").classList.toggle("latched", latched);
  if (humanoid.renderTorque) humanoid.renderTorque(s.torque_enabled);
  setText("st-mode", s.mode + (s.fallen ? " (fallen)" : ""));
  setText("st-pose", `x ${fmt(s.pose.x)} m, y ${fmt(s.pose.y)} m, z ${fmt(s.pose.z)} m, yaw ${fmt(s.pose.yaw_rad * 180 / Math.PI, 0)}°`);
  setText("st-tilt", `${fmt(s.tilt_deg, 1)}°`);
  const body = s.proprioception;
  if (body) {
    const [w, x, y, z] = body.orientation;
    const roll = Math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y)) * 180 / Math.PI;
    const pitch = Math.asin(Math.max(-1, Math.min(1, 2 * (w * y - z * x)))) * 180 / Math.PI;
    const gyro = Math.hypot(...body.angular_velocity);
    setText("st-imu", `${fmt(roll, 1)}° / ${fmt(pitch, 1)}°, ${fmt(gyro, 2)} rad/s`);
    const sum = (a) => a.reduce((p, q) => p + q, 0);
    setText("st-feet", `${fmt(sum(body.left_foot_n), 1)} N / ${fmt(sum(body.right_foot_n), 1)} N`);
  }
  setText("st-time", `${fmt(s.sim_time_s, 1)} s`);
  setText("st-rtf", fmt(s.control.rtf, 2));
  setText("st-tick", `${fmt(s.control.tick_p50_ms, 2)} / ${fmt(s.control.tick_p99_ms, 2)} ms, ${s.control.deadline_misses} missed`);
  setText("st-held", s.held_object || "nothing");
  if (humanoid.renderLocomotion) humanoid.renderLocomotion(s.locomotion);
  if (humanoid.renderPerception) humanoid.renderPerception(s.perception, s.locomotion);
  if (humanoid.renderBehaviour) humanoid.renderBehaviour(s.behaviour);
  renderPlan(s.plan);
}

let lastPlanKey = "";
function renderPlan(plan) {
  const key = JSON.stringify(plan);
  if (key === lastPlanKey) return;
  lastPlanKey = key;
  const list = $("plan-steps");
  list.innerHTML = "";
  const awaiting = plan && plan.state === "awaiting_approval";
  $("approval-row").hidden = !awaiting;
  $("pause").textContent = plan && plan.state === "paused" ? "Resume" : "Pause";
  if (!plan) { $("plan-text").textContent = "no plan yet"; $("plan-state").textContent = ""; return; }
  $("plan-text").textContent = `"${plan.command_text}", plan ${plan.plan_id}, revision ${plan.revision}`;
  $("plan-state").textContent = plan.state.replace("_", " ") + (plan.replanning ? ": replanning" : "");
  const source = humanoid.planSources[plan.plan_id];
  $("plan-source").textContent = source || "";
  for (const step of plan.steps) {
    const li = document.createElement("li");
    li.dataset.state = step.state;
    const args = Object.values(step.args).join(", ");
    li.innerHTML = `<code></code><span class="step-state st-${step.state}">${step.state}</span><span class="step-detail"></span>`;
    li.querySelector("code").textContent = `${step.action}(${args})`;
    li.querySelector(".step-detail").textContent = step.detail || "";
    list.appendChild(li);
  }
}

function addEvent(e) {
  humanoid.events.push(e);
  if (e.kind === "speech/say" && humanoid.onSay && humanoid.connectedAt && e.wall_time_s > humanoid.connectedAt) {
    humanoid.onSay(e.data.text || e.message);  // new ones only: not the history sent on connecting
  }
  if (e.kind === "speech/heard" && humanoid.onRobotHeard && humanoid.connectedAt && e.wall_time_s > humanoid.connectedAt) {
    humanoid.onRobotHeard(e.data);  // the robot's own microphone heard a command
  }
  if (e.kind === "plan/created") {
    // who planned it, how long it took, and why the configured planner's plan was not used as it came
    const d = e.data;
    const ms = d.planning_ms ? ` in ${fmt(d.planning_ms, 0)} ms` : "";
    const notes = d.notes && d.notes.length ? ` (${d.notes.join("; ")})` : "";
    humanoid.planSources[d.plan_id] = d.planner === "operator" ? "written by the operator" : `planned by ${d.planner}${ms}${notes}`;
    lastPlanKey = "";
    if (humanoid.state) renderPlan(humanoid.state.plan);
  }
  if (e.kind === "estop/latched" && e.data.latency_ms !== undefined) {
    humanoid.estopLatencies.push(e.data.latency_ms);
    humanoid.estopParts.push({ total: e.data.latency_ms, server: e.data.server_latency_ms, robot: e.data.worker_latency_ms,
                               source: e.data.source });
    $("st-estop").textContent = `${fmt(e.data.latency_ms, 1)} ms (press to control loop)`;
  }
  const li = document.createElement("li");
  li.className = "lvl-" + e.level;
  li.textContent = `${new Date(e.wall_time_s * 1000).toLocaleTimeString()} [${e.kind}] ${e.message}`;
  const list = $("events");
  list.prepend(li);
  while (list.children.length > 200) list.removeChild(list.lastChild);
}

loadConfig();
connect();
connectStop();
