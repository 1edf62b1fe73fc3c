// Behaviours panel: pick one, set its typed parameters, start, pause, resume, stop; its state machine, progress
// and feedback live from the state the WebSocket pushes.
"use strict";

(() => {
  const $ = (id) => document.getElementById(id);
  const panel = { list: [], chosen: null, lastKey: "" };

  async function load() {
    const r = await fetch("/api/behaviours");
    if (!r.ok) return;
    const body = await r.json();
    panel.list = body.behaviours;
    const select = $("beh-name");
    select.innerHTML = "";
    for (const b of panel.list) {
      const option = document.createElement("option");
      option.value = b.name;
      option.textContent = b.package ? `${b.name} (${b.package})` : b.name;
      select.appendChild(option);
    }
    choose(select.value);
  }

  // the world's names a parameter's values come from ("places", "objects"), and values allowed besides them
  function namesFor(param) {
    const config = window.humanoid.config || {};
    const names = param.choices ? (config[param.choices] || []) : [];
    return [...(param.extra || []), ...names];
  }

  function inputFor(param) {
    const label = document.createElement("label");
    label.className = "param";
    label.title = param.doc || "";
    label.dataset.param = param.name;
    const caption = document.createElement("span");
    caption.textContent = param.name;
    label.appendChild(caption);
    let input;
    if (param.kind === "bool") {
      input = document.createElement("input");
      input.type = "checkbox";
      input.checked = Boolean(param.default);
    } else if (param.kind === "list[str]" && param.choices) {
      input = document.createElement("select");
      input.multiple = true;
      for (const name of namesFor(param)) {
        const option = new Option(name, name, false, (param.default || []).includes(name));
        input.appendChild(option);
      }
    } else if (param.kind === "str" && param.choices) {
      input = document.createElement("select");
      for (const name of namesFor(param)) input.appendChild(new Option(name || "(any)", name, false, name === param.default));
    } else {
      input = document.createElement("input");
      if (param.kind === "int" || param.kind === "float") {
        input.type = "number";
        input.step = param.kind === "int" ? "1" : "any";
        if (param.minimum !== null) input.min = param.minimum;
        if (param.maximum !== null) input.max = param.maximum;
      }
      input.value = Array.isArray(param.default) ? param.default.join(", ") : param.default;
    }
    input.name = param.name;
    input.setAttribute("aria-label", `${param.name}: ${param.doc || param.kind}`);
    label.appendChild(input);
    return label;
  }

  function choose(name) {
    panel.chosen = panel.list.find((b) => b.name === name) || null;
    const form = $("beh-params");
    form.innerHTML = "";
    $("beh-desc").textContent = panel.chosen ? panel.chosen.description : "no behaviours installed";
    if (!panel.chosen) return;
    for (const param of panel.chosen.params) form.appendChild(inputFor(param));
  }

  function readParams() {
    const params = {};
    for (const param of panel.chosen.params) {
      const input = $("beh-params").elements[param.name];
      if (param.kind === "bool") params[param.name] = input.checked;
      else if (input.multiple) params[param.name] = [...input.selectedOptions].map((o) => o.value);
      else if (param.kind === "list[str]") params[param.name] = input.value.split(",").map((v) => v.trim()).filter(Boolean);
      else params[param.name] = input.value;  // text: the robot types and checks it (a 422 names a bad one)
    }
    return params;
  }

  function result(text, isError) {
    const el = $("beh-result");
    el.textContent = text;
    el.className = "result " + (isError ? "error" : "ok");
  }

  function markBad(detail) {
    for (const label of $("beh-params").querySelectorAll("label.param")) label.classList.remove("bad");
    for (const error of (detail && detail.errors) || []) {
      const name = error.split(":")[0];
      const label = $("beh-params").querySelector(`label[data-param="${name}"]`);
      if (label) label.classList.add("bad");
    }
  }

  async function call(url, body) {
    const r = await fetch(url, { method: "POST", headers: { "Content-Type": "application/json" },
      body: body ? JSON.stringify(body) : undefined });
    const data = await r.json().catch(() => ({ detail: r.statusText }));
    if (!r.ok) {
      const detail = data.detail || {};
      markBad(detail);
      result(typeof detail === "string" ? detail : (detail.message || "refused"), true);
    } else {
      markBad(null);
      result(data.message, false);
    }
  }

  $("beh-name").addEventListener("change", (ev) => choose(ev.target.value));
  $("beh-start").addEventListener("click", () => {
    if (panel.chosen) call(`/api/behaviours/${encodeURIComponent(panel.chosen.name)}/start`, { params: readParams(), source: "panel" });
  });
  $("beh-pause").addEventListener("click", () => call("/api/behaviours/pause"));
  $("beh-resume").addEventListener("click", () => call("/api/behaviours/resume"));
  $("beh-stop").addEventListener("click", () => call("/api/behaviours/stop"));

  window.humanoid.renderBehaviour = (status) => {
    const key = JSON.stringify(status);
    if (key === panel.lastKey) return;
    panel.lastKey = key;
    const state = $("beh-state");
    const running = status && ["queued", "running"].includes(status.state);
    const paused = status && status.state === "paused";
    $("beh-pause").disabled = !running;
    $("beh-resume").disabled = !paused;
    $("beh-stop").disabled = !(running || paused);
    if (!status) { state.textContent = ""; return; }
    state.textContent = `${status.name}: ${status.state}`;
    state.className = "badge " + (status.state === "failed" ? "badge-err" : running || paused ? "badge-warn" : "badge-ok");
    const info = panel.list.find((b) => b.name === status.name);
    const machine = $("beh-machine");
    machine.innerHTML = "";
    for (const name of (info ? info.states : [status.machine_state])) {
      const li = document.createElement("li");
      li.textContent = name;
      if (name === status.machine_state) li.className = "current";
      machine.appendChild(li);
    }
    $("beh-progress").value = status.progress;
    $("beh-reason").textContent = status.reason || "";
    const feedback = $("beh-feedback");
    feedback.innerHTML = "";
    for (const line of status.feedback.slice(-12)) {
      const li = document.createElement("li");
      li.textContent = line;
      feedback.appendChild(li);
    }
  };

  // the config (places, objects) comes first: the parameters' choices are its names
  const ready = () => (window.humanoid.config ? load() : setTimeout(ready, 100));
  ready();
})();
