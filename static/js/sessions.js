// Sessions page: list with paging, and one session's commands, plans (each revision) and event timeline.
"use strict";

const $ = (id) => document.getElementById(id);
const PAGE = 25;
let offset = 0;

const when = (iso) => (iso ? new Date(iso).toLocaleString() : "–");
function cell(text) { const td = document.createElement("td"); td.textContent = text; return td; }

async function loadList() {
  const r = await fetch(`/api/sessions?limit=${PAGE}&offset=${offset}`);
  const data = await r.json();
  $("total").textContent = `${data.total}`;
  const body = $("sessions");
  body.innerHTML = "";
  for (const s of data.items) {
    const tr = document.createElement("tr");
    tr.className = "clickable";
    tr.dataset.id = s.id;
    [s.id, s.kind, when(s.started_at), s.ended_at ? when(s.ended_at) : "running", s.seed, s.command_count,
     s.estop_count, s.outcome || (s.ended_at ? "ended" : "–")].forEach((v) => tr.appendChild(cell(String(v))));
    tr.addEventListener("click", () => loadDetail(s.id));
    body.appendChild(tr);
  }
  $("prev").disabled = offset === 0;
  $("next").disabled = offset + PAGE >= data.total;
}

async function loadDetail(id) {
  const r = await fetch(`/api/sessions/${id}`);
  if (!r.ok) return;
  const s = await r.json();
  $("detail").hidden = false;
  $("detail-title").textContent = `Session ${s.id} (${s.kind}, seed ${s.seed}), ${s.state_sample_count} state samples`;
  const transcripts = $("transcripts");
  transcripts.innerHTML = s.transcripts.length ? "" : '<li class="muted">nothing spoken</li>';
  for (const t of s.transcripts) {
    const li = document.createElement("li");
    li.textContent = `${when(t.received_at)} [${t.source}] "${t.text}" (confidence ${t.confidence.toFixed(2)}, ` +
      `${t.engine}${t.in_grammar ? "" : ", free speech"}, ${t.audio_s.toFixed(1)} s) `;
    if (t.audio_url) {
      const audio = document.createElement("audio");
      audio.controls = true;
      audio.preload = "none";
      audio.src = t.audio_url;
      li.appendChild(audio);
    }
    transcripts.appendChild(li);
  }
  const commands = $("commands");
  commands.innerHTML = "";
  for (const c of s.commands) {
    const li = document.createElement("li");
    li.textContent = `${when(c.received_at)} [${c.source}] "${c.text}" ` +
      (c.accepted ? "accepted" : `refused (${c.refusal}): ${(c.errors || []).join("; ")}`);
    commands.appendChild(li);
  }
  const plans = $("plans");
  plans.innerHTML = "";
  for (const p of s.plans) {
    const div = document.createElement("div");
    const title = document.createElement("p");
    title.textContent = `Plan ${p.plan_id} for "${p.text}" (revision ${p.revision}): ${p.state}`;
    const ol = document.createElement("ol");
    ol.className = "steps";
    for (const st of p.steps) {
      const li = document.createElement("li");
      const args = Object.values(st.args).join(", ");
      li.textContent = `${st.action}(${args}): ${st.state}${st.detail ? " (" + st.detail + ")" : ""}`;
      ol.appendChild(li);
    }
    div.append(title, ol);
    plans.appendChild(div);
  }
  const timeline = $("timeline");
  timeline.innerHTML = "";
  for (const e of s.events) {
    const li = document.createElement("li");
    li.className = "lvl-" + e.level;
    li.textContent = `${when(e.wall_time)} t=${e.sim_time_s.toFixed(2)}s [${e.kind}] ${e.message}`;
    timeline.appendChild(li);
  }
}

$("prev").addEventListener("click", () => { offset = Math.max(0, offset - PAGE); loadList(); });
$("next").addEventListener("click", () => { offset += PAGE; loadList(); });
loadList().then(() => {
  const wanted = new URLSearchParams(location.search).get("id");
  if (wanted) loadDetail(Number(wanted));
});
