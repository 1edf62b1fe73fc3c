// Who is at this console and who operates the robot. With access control on: a viewer's page greys out what
// needs an operator (the e-stop stays for everyone); an operator takes control, or takes it over, explicitly.
(function () {
  const $ = (id) => document.getElementById(id);
  const me = { name: null, role: null, auth: false };

  function render(control) {
    const holder = control && control.holder;
    const box = $("access");
    if (!me.auth) { box.hidden = true; return; }
    box.hidden = false;
    $("access-user").textContent = `${me.name} (${me.role})`;
    $("access-holder").textContent = holder ? `control: ${holder}` : "control: free";
    const mine = holder === me.name;
    $("access-holder").className = "badge " + (mine ? "badge-ok" : holder ? "badge-warn" : "");
    const take = $("access-take");
    take.hidden = me.role !== "operator" || mine;
    take.textContent = holder ? `Take over from ${holder}` : "Take control";
    $("access-release").hidden = !mine;
    document.body.classList.toggle("viewer", me.role !== "operator");
  }

  async function post(path, body) {
    const r = await fetch(path, { method: "POST", headers: { "Content-Type": "application/json" },
                                  body: JSON.stringify(body || {}) });
    const data = await r.json().catch(() => ({}));
    if (!r.ok && window.humanoid.showResult) window.humanoid.showResult(data.detail.message || r.statusText, true);
    return data;
  }

  async function start() {
    const r = await fetch("/api/auth/me");
    if (r.status === 401) { location.href = "/login"; return; }
    Object.assign(me, await r.json());
    render(me.control);
    $("access-take").addEventListener("click", () => {
      const holder = window.humanoid.control && window.humanoid.control.holder;
      if (holder && holder !== me.name && !confirm(`Take control from ${holder}? They will be told.`)) return;
      post("/api/control/take", { take_over: true }).then((c) => c.holder !== undefined && render(c));
    });
    $("access-release").addEventListener("click", () => post("/api/control/release").then(render));
    $("access-logout").addEventListener("click", async () => {
      await fetch("/api/auth/logout", { method: "POST" });
      location.href = "/login";
    });
  }

  window.humanoid.onControl = (control) => { window.humanoid.control = control; render(control); };
  start();
})();
