"""Signed tokens that let a logged-in page open the 3D views (their own ports, another site for the browser).

Why a token and not the login cookie: the 3D views are cross-site frames (so that their software WebGL renders in
a process of its own and never delays the e-stop), and a browser does not send a SameSite=Strict cookie to a
cross-site frame. The page asks for a token (`GET /api/scene`, which needs the login) and puts it in the
frame's address; the 3D views' gate checks it on every request and WebSocket. A token says who it was issued to
and is bound to the login it came from: it stops working when that login ends (log out, or its 12 h are up).
"""

from __future__ import annotations

import base64
import hashlib
import hmac
import json
import secrets
import threading
import time
from dataclasses import dataclass

from app.auth.roles import Principal, Role

SIGNATURE_BYTES = 16


@dataclass(frozen=True)
class SceneGrant:
    """Who may look at the 3D views (and, if an operator in control, click in them), and until when."""

    user: str
    role: Role
    login: str  # which login it came from (a digest): ending that login revokes it
    expires_at: float  # Unix time

    @property
    def principal(self) -> Principal:
        return Principal(self.user, self.role)


def login_id(credential: str) -> str:
    """A short, non-secret name for a login cookie or API token (what revocations refer to)."""
    return hashlib.sha256(b"scene-login:" + credential.encode()).hexdigest()[:24]


def _b64(data: bytes) -> str:
    return base64.urlsafe_b64encode(data).rstrip(b"=").decode()


def _unb64(text: str) -> bytes:
    return base64.urlsafe_b64decode(text + "=" * (-len(text) % 4))


class SceneTokens:
    """Issues and checks the tokens. The same secret is given to every process that checks them (the 3D views'
    own process); revocations reach those processes as they happen (`revoke`)."""

    def __init__(self, secret: bytes | None = None) -> None:
        self.secret = secret or secrets.token_bytes(32)  # new at every start: a restart ends every token
        self._revoked: set[str] = set()
        self._lock = threading.Lock()

    def issue(self, who: Principal, login: str, expires_at: float) -> str:
        payload = _b64(json.dumps([who.name, who.role.value, login, round(expires_at)], separators=(",", ":")).encode())
        return f"{payload}.{self._sign(payload)}"

    def verify(self, token: str, now: float | None = None) -> SceneGrant | None:
        """The grant a token carries, or None if it is forged, malformed, expired or revoked."""
        payload, _, signature = token.partition(".")
        if not payload or not hmac.compare_digest(signature, self._sign(payload)):
            return None
        try:
            name, role, login, expires_at = json.loads(_unb64(payload))
            grant = SceneGrant(str(name), Role(role), str(login), float(expires_at))
        except (ValueError, TypeError):
            return None
        if grant.expires_at <= (time.time() if now is None else now):
            return None
        with self._lock:
            if grant.login in self._revoked:
                return None
        return grant

    def revoke(self, login: str) -> None:
        with self._lock:
            self._revoked.add(login)

    def _sign(self, payload: str) -> str:
        return _b64(hmac.new(self.secret, payload.encode(), hashlib.sha256).digest()[:SIGNATURE_BYTES])
