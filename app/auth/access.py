"""Access control for the web app: who a request comes from (a login cookie, an API token, or nobody), whether
access control is on at all, and the guard against serving beyond this computer without it.

Modes (`HUMANOID_AUTH`): "auto" (on once a user exists), "on" (users required), "off" (everyone who reaches the
app operates it: only allowed on a loopback address)."""

from __future__ import annotations

import ipaddress
import threading
import time
from dataclasses import dataclass, field

from app.auth.roles import LOCAL_OPERATOR, Principal
from app.auth.secrets import new_token, token_digest
from app.auth.store import UserStore

COOKIE_NAME = "humanoid_session"
LOGIN_TTL_S = 12 * 3600
MAX_FAILED_LOGINS = 5  # per name and per client address, then a pause
LOCKOUT_S = 30.0
USER_COUNT_TTL_S = 1.0


class InsecureBind(RuntimeError):
    pass


def is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False  # a name other than localhost may resolve anywhere


@dataclass
class _Throttle:
    failures: dict[str, list[float]] = field(default_factory=dict)

    def blocked_for(self, key: str, now: float) -> float:
        recent = [t for t in self.failures.get(key, []) if now - t < LOCKOUT_S]
        self.failures[key] = recent
        return LOCKOUT_S - (now - recent[-MAX_FAILED_LOGINS]) if len(recent) >= MAX_FAILED_LOGINS else 0.0

    def fail(self, key: str, now: float) -> None:
        self.failures.setdefault(key, []).append(now)

    def clear(self, key: str) -> None:
        self.failures.pop(key, None)


class LoginThrottled(Exception):
    def __init__(self, retry_after_s: float) -> None:
        super().__init__(f"too many failed logins: try again in {retry_after_s:.0f} s")
        self.retry_after_s = retry_after_s


class AccessControl:
    def __init__(self, mode: str, store: UserStore, host: str) -> None:
        self.mode = mode
        self.store = store
        self.host = host
        self._logins: dict[str, tuple[Principal, float]] = {}  # cookie digest -> who, until when
        self._lock = threading.Lock()
        self._throttle = _Throttle()
        self._count, self._counted_at = 0, -1e9

    @property
    def enabled(self) -> bool:
        return self.mode == "on" or (self.mode == "auto" and self._user_count() > 0)

    def _user_count(self) -> int:
        """Counted at most once a second (every request asks; `humanoid users add` may run meanwhile)."""
        now = time.monotonic()
        if now - self._counted_at > USER_COUNT_TTL_S:
            self._count, self._counted_at = self.store.count(), now
        return self._count

    def check_exposure(self) -> None:
        """Refuse to serve beyond this computer without access control (anyone on the network could drive)."""
        if self.mode == "on" and self.store.count() == 0:
            raise InsecureBind(
                "access control is on (HUMANOID_AUTH=on) but there are no users: add one with "
                "`humanoid users add NAME --role operator`"
            )
        if not is_loopback(self.host) and not self.enabled:
            raise InsecureBind(
                f"refusing to serve on {self.host} without access control: anyone who can reach it could move the "
                "robot. Add an operator (`humanoid users add NAME --role operator`), or serve on 127.0.0.1."
            )

    # who is asking --------------------------------------------------------------------------------------------

    def identify(self, cookie: str | None, authorization: str | None) -> Principal | None:
        """The caller, or None if access control is on and they proved nothing."""
        if not self.enabled:
            return LOCAL_OPERATOR
        if authorization and authorization.lower().startswith("bearer "):
            return self.store.check_token(authorization[7:].strip())
        if cookie:
            with self._lock:
                entry = self._logins.get(token_digest(cookie))
            if entry is not None and entry[1] > time.time():
                return entry[0]
        return None

    def login(self, name: str, password: str, client: str) -> tuple[Principal, str] | None:
        """(who, the cookie value) for a right password; None for a wrong one; LoginThrottled after too many."""
        now = time.monotonic()
        keys = (f"name:{name}", f"client:{client}")
        wait = max(self._throttle.blocked_for(k, now) for k in keys)
        if wait > 0:
            raise LoginThrottled(wait)
        principal = self.store.check_password(name, password)
        if principal is None:
            for key in keys:
                self._throttle.fail(key, now)
            return None
        for key in keys:
            self._throttle.clear(key)
        cookie = new_token()
        with self._lock:
            self._logins[token_digest(cookie)] = (principal, time.time() + LOGIN_TTL_S)
            self._logins = {k: v for k, v in self._logins.items() if v[1] > time.time()}
        return principal, cookie

    def login_expiry(self, cookie: str) -> float | None:
        """When the login behind `cookie` ends (Unix time), or None if it is not a login."""
        with self._lock:
            entry = self._logins.get(token_digest(cookie))
        return entry[1] if entry is not None else None

    def logout(self, cookie: str | None) -> None:
        if cookie:
            with self._lock:
                self._logins.pop(token_digest(cookie), None)
