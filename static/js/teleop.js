// Teleop: WASD + QE on the keyboard and an on-screen joystick drive the robot's velocity over the WebSocket.
// The server's deadman stops the robot 300 ms after the last message, so while any input is held this page
// repeats it every 100 ms; letting go sends an explicit stop. Leaving the page (blur, hidden tab) lets go.
"use strict";

(() => {
  const $ = (id) => document.getElementById(id);
  const SEND_PERIOD_MS = 100;
  // Speeds at full key press or full joystick deflection (the server clips to the walking limits).
  const SPEED = { vx: 0.15, vxBack: 0.1, vy: 0.05, yaw: 0.6 };
  const KEYS = { w: "fwd", s: "back", a: "left", d: "right", q: "turnLeft", e: "turnRight" };
  const held = new Set();
  const stick = { active: false, x: 0, y: 0 };
  let timer = null;
  const teleop = { sent: 0, last: null };
  window.humanoid.teleop = teleop;

  function velocity() {
    let vx = 0, vy = 0, yaw = 0;
    if (held.has("fwd")) vx += SPEED.vx;
    if (held.has("back")) vx -= SPEED.vxBack;
    if (held.has("left")) vy += SPEED.vy;
    if (held.has("right")) vy -= SPEED.vy;
    if (held.has("turnLeft")) yaw += SPEED.yaw;
    if (held.has("turnRight")) yaw -= SPEED.yaw;
    if (stick.active) {
      vx += stick.y >= 0 ? stick.y * SPEED.vx : stick.y * SPEED.vxBack; // up is forward
      yaw += -stick.x * SPEED.yaw; // right turns clockwise
    }
    return { vx, vy, yaw_rate: yaw };
  }

  function send(message) {
    const ws = window.humanoid.ws;
    if (ws && ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify(message));
  }

  function tick() {
    const v = velocity();
    teleop.last = v;
    teleop.sent += 1;
    send({ type: "teleop", ...v });
    $("teleop-cmd").textContent = `vx ${v.vx.toFixed(2)} m/s, vy ${v.vy.toFixed(2)} m/s, turn ${v.yaw_rate.toFixed(2)} rad/s`;
  }

  function inputChanged() {
    const driving = held.size > 0 || stick.active;
    if (driving && timer === null) {
      tick();
      timer = setInterval(tick, SEND_PERIOD_MS);
    } else if (driving) {
      tick(); // a new key: no need to wait for the next period
    } else if (timer !== null) {
      clearInterval(timer);
      timer = null;
      send({ type: "teleop_stop" });
      $("teleop-cmd").textContent = "released: stopping";
    }
  }

  function releaseAll() {
    held.clear();
    stick.active = false;
    stick.x = stick.y = 0;
    $("joystick-knob").style.transform = "translate(-50%, -50%)";
    inputChanged();
  }

  const typing = () => ["INPUT", "TEXTAREA", "SELECT"].includes(document.activeElement.tagName);
  document.addEventListener("keydown", (ev) => {
    const action = KEYS[ev.key.toLowerCase()];
    if (!action || typing() || ev.ctrlKey || ev.metaKey || ev.altKey) return;
    ev.preventDefault();
    if (!held.has(action)) { held.add(action); inputChanged(); }
  });
  document.addEventListener("keyup", (ev) => {
    const action = KEYS[ev.key.toLowerCase()];
    if (action && held.delete(action)) inputChanged();
  });
  window.addEventListener("blur", releaseAll);
  document.addEventListener("visibilitychange", () => { if (document.hidden) releaseAll(); });

  // ---- joystick: drag the knob; up/down walks, left/right turns ------------------------------------------------
  const pad = $("joystick");
  function moveStick(ev) {
    const r = pad.getBoundingClientRect();
    const radius = r.width / 2;
    let x = (ev.clientX - r.left - radius) / radius;
    let y = -(ev.clientY - r.top - radius) / radius;
    const n = Math.hypot(x, y);
    if (n > 1) { x /= n; y /= n; }
    const dead = 0.12; // a resting thumb does not walk
    stick.x = Math.abs(x) < dead ? 0 : x;
    stick.y = Math.abs(y) < dead ? 0 : y;
    $("joystick-knob").style.transform = `translate(calc(-50% + ${x * radius}px), calc(-50% + ${-y * radius}px))`;
  }
  pad.addEventListener("pointerdown", (ev) => {
    pad.setPointerCapture(ev.pointerId);
    stick.active = true;
    moveStick(ev);
    inputChanged();
  });
  pad.addEventListener("pointermove", (ev) => { if (stick.active) moveStick(ev); });
  for (const name of ["pointerup", "pointercancel", "lostpointercapture"]) {
    pad.addEventListener(name, () => { if (stick.active) releaseAll(); });
  }

  // ---- postures and reset --------------------------------------------------------------------------------------
  async function action(url, body) {
    const r = await fetch(url, { method: "POST", headers: { "Content-Type": "application/json" },
      body: body ? JSON.stringify(body) : undefined });
    const data = await r.json().catch(() => ({ detail: r.statusText }));
    const message = r.ok ? data.message : (data.detail && data.detail.message) || JSON.stringify(data.detail);
    $("teleop-result").textContent = message;
    $("teleop-result").className = "result " + (r.ok ? "ok" : "error");
  }
  $("stand").addEventListener("click", () => action("/api/posture", { posture: "stand" }));
  $("crouch").addEventListener("click", () => action("/api/posture", { posture: "crouch" }));
  $("reset").addEventListener("click", () => action("/api/reset"));
  // the real robot's servos: off at start-up until the operator turns them on (hidden in simulation)
  $("torque").addEventListener("click", () => {
    const on = window.humanoid.state && window.humanoid.state.torque_enabled;
    action("/api/torque", { enabled: !on });
  });
  window.humanoid.renderTorque = (enabled) => {
    window.humanoid.setHidden("torque", enabled === null || enabled === undefined);
    window.humanoid.setText("torque", enabled ? "Torque off" : "Torque on");
    $("torque").classList.toggle("primary", !enabled);
  };

  // refusals come back on the socket (e.g. a plan is running, e-stop latched)
  window.humanoid.onTeleopAck = (m) => {
    $("teleop-result").textContent = m.message;
    $("teleop-result").className = "result error";
  };

  window.humanoid.renderLocomotion = (loco) => {
    if (!loco) return;
    const [vx, vy, w] = loco.velocity;
    const [ex, ey, eyaw] = loco.estimated_pose;
    window.humanoid.setText("st-walk", `${loco.phase}, ${loco.posture}; ${vx.toFixed(2)} / ${vy.toFixed(2)} m/s, ` +
      `${w.toFixed(2)} rad/s`);
    window.humanoid.setText("st-odom", `x ${ex.toFixed(2)} m, y ${ey.toFixed(2)} m, yaw ${(eyaw * 180 / Math.PI).toFixed(0)}°`);
  };
})();
