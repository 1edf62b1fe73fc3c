// Log in, then back to the console. The cookie is HttpOnly: this page never sees it.
document.getElementById("login-form").addEventListener("submit", async (ev) => {
  ev.preventDefault();
  const error = document.getElementById("login-error");
  error.hidden = true;
  const r = await fetch("/api/auth/login", {
    method: "POST", headers: { "Content-Type": "application/json" },
    body: JSON.stringify({ name: document.getElementById("login-name").value,
                           password: document.getElementById("login-password").value }),
  });
  if (r.ok) { location.href = "/"; return; }
  const body = await r.json().catch(() => ({}));
  error.textContent = (body.detail && body.detail.message) || `login failed (${r.status})`;
  error.hidden = false;
});
