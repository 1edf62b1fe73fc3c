// Diagnostics panel: the alarm banner (every status not OK), the health badge, live sparklines of the signals
// an operator watches (CPU, control tick, hottest servo, battery), and every group's statuses with key-values.
// Fed once a second by the WebSocket's {"type": "diagnostics"} message (same JSON as GET /api/diagnostics).
"use strict";

(() => {
  const $ = (id) => document.getElementById(id);
  const LEVELS = ["OK", "WARN", "ERROR", "STALE"];
  const HISTORY = 300; // samples (5 minutes at 1 Hz)
  const series = { cpu: [], tick: [], servo: [], battery: [] };

  const value = (d, name, key) => {
    for (const g of Object.values(d.groups)) {
      const s = g.statuses.find((x) => x.name === name);
      if (s) return s.values[key];
    }
    return undefined;
  };

  function push(list, v) {
    list.push(typeof v === "number" && isFinite(v) ? v : null);
    if (list.length > HISTORY) list.shift();
  }

  function spark(id, data, { min = null, max = null, warn = null } = {}) {
    const canvas = $(id);
    const ctx = canvas.getContext("2d");
    const w = canvas.width, h = canvas.height;
    ctx.clearRect(0, 0, w, h);
    const vals = data.filter((v) => v !== null);
    if (!vals.length) return;
    const lo = min ?? Math.min(...vals), hi = Math.max(max ?? -Infinity, ...vals, warn ?? -Infinity);
    const y = (v) => h - 3 - ((v - lo) / (hi - lo || 1)) * (h - 6);
    if (warn !== null) {
      ctx.strokeStyle = "#d49a1f"; ctx.setLineDash([3, 3]);
      ctx.beginPath(); ctx.moveTo(0, y(warn)); ctx.lineTo(w, y(warn)); ctx.stroke(); ctx.setLineDash([]);
    }
    ctx.strokeStyle = "#6cb6ff"; ctx.lineWidth = 1.5; ctx.beginPath();
    let started = false;
    data.forEach((v, i) => {
      if (v === null) { started = false; return; }
      const x = (i / (HISTORY - 1)) * w;
      if (started) ctx.lineTo(x, y(v)); else { ctx.moveTo(x, y(v)); started = true; }
    });
    ctx.stroke();
  }

  function pill(level) { return `<span class="level-pill l${level}">${LEVELS[level]}</span>`; }
  const esc = (t) => String(t).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" })[c]);
  const fmt = (v) => (typeof v === "number" ? (Number.isInteger(v) ? v : v.toFixed(Math.abs(v) < 10 ? 3 : 1)) : v);

  let bannerKey = "";
  function renderBanner(d) {
    const banner = $("alarm-banner");
    const alarms = d.alarms;
    const key = alarms.map((a) => `${a.level}|${a.name}|${a.message}`).join("\n");
    if (key === bannerKey) return; // unchanged: no DOM work (a software-rendered page repaints what it touches)
    bannerKey = key;
    if (!alarms.length) { banner.hidden = true; banner.replaceChildren(); return; } // a hidden banner keeps no old alarm
    banner.hidden = false;
    banner.classList.toggle("banner-error", alarms.some((a) => a.level === 2));
    const stop = alarms.some((a) => a.stops_motion && a.level === 2) ? " The robot is stopped until this is fixed." : "";
    banner.innerHTML = `<div>${alarms.length} alarm${alarms.length > 1 ? "s" : ""}.${stop}</div><ul>` +
      alarms.slice(0, 6).map((a) => `<li data-name="${esc(a.name)}">${LEVELS[a.level]} ${esc(a.name)}: ${esc(a.message)}</li>`).join("") +
      (alarms.length > 6 ? `<li>… and ${alarms.length - 6} more (see Diagnostics)</li>` : "") + "</ul>";
  }

  // Each group is a <details>: its summary (level, counts) always, its table of statuses only while it is open,
  // so a closed panel costs almost nothing a second.
  function groupRows(g) {
    return g.statuses.map((s) => {
      const kv = Object.entries(s.values).map(([k, v]) => `${esc(k)}=${esc(fmt(v))}`).join(" · ");
      return `<tr class="lvl-${s.level}" data-name="${esc(s.name)}"><td>${pill(s.level)}</td><td>${esc(s.name.split("/").slice(1).join("/"))}</td>` +
        `<td>${esc(s.message)}<br><span class="muted">${kv}</span></td></tr>`;
    }).join("");
  }

  function renderGroups(d) {
    const box = $("diag-groups");
    if (box.querySelector("p")) box.innerHTML = "";
    for (const [name, g] of Object.entries(d.groups)) {
      let el = box.querySelector(`details[data-group="${name}"]`);
      if (!el) {
        el = document.createElement("details");
        el.dataset.group = name;
        el.innerHTML = "<summary></summary><table></table>";
        el.addEventListener("toggle", () => { if (el.open && humanoid.diagnostics) renderGroups(humanoid.diagnostics); });
        box.appendChild(el);
      }
      const bad = g.statuses.filter((s) => s.level !== 0).length;
      const summary = `${pill(g.level)}${esc(name)} <span class="muted">(${g.statuses.length}${bad ? `, ${bad} not OK` : ""})</span>`;
      const head = el.querySelector("summary");
      if (head.innerHTML !== summary) head.innerHTML = summary;
      const table = el.querySelector("table");
      if (el.open) table.innerHTML = groupRows(g);
      else if (table.innerHTML) table.innerHTML = "";
    }
  }

  humanoid.onDiagnostics = (d) => {
    humanoid.diagnostics = d;
    const health = $("health");
    health.textContent = "health: " + d.level_name;
    health.className = "badge " + ["badge-ok", "badge-warn", "badge-err", "badge-warn"][d.level];
    $("diag-level").textContent = d.level_name;
    $("diag-level").className = health.className;
    renderBanner(d);
    renderGroups(d);
    const cpu = value(d, "compute/cpu", "usage_pct");
    const tick = value(d, "control/loop", "tick_p99_ms");
    const temps = (d.groups.servos ? d.groups.servos.statuses : []).map((s) => s.values.temperature_c);
    const hottest = temps.length ? Math.max(...temps) : undefined;
    const volts = value(d, "power/battery", "voltage_v");
    const soc = value(d, "power/battery", "state_of_charge_pct");
    push(series.cpu, cpu); push(series.tick, tick); push(series.servo, hottest); push(series.battery, volts);
    const t = (humanoid.config && humanoid.config.diagnostics_thresholds) || {};
    const hz = (humanoid.config && humanoid.config.control_hz) || 100;
    spark("spark-cpu", series.cpu, { min: 0, max: 100, warn: t.cpu_warn_pct ?? null });
    spark("spark-tick", series.tick, { min: 0, warn: t.tick_p99_warn_fraction ? (t.tick_p99_warn_fraction * 1000) / hz : null });
    spark("spark-servo", series.servo, { warn: t.servo_temperature_warn_c ?? null });
    spark("spark-battery", series.battery, { warn: t.battery_warn_cell_v ? t.battery_warn_cell_v * 6 : null });
    $("v-cpu").textContent = cpu !== undefined ? `${cpu.toFixed(0)} %` : "–";
    $("v-tick").textContent = tick !== undefined ? `${tick.toFixed(1)} ms` : "–";
    $("v-servo").textContent = hottest !== undefined ? `${hottest.toFixed(1)} °C` : "–";
    $("v-battery").textContent = volts !== undefined ? `${volts.toFixed(2)} V · ${soc.toFixed(0)} %` : "–";
  };
})();
