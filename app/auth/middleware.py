"""Every request to the API, the metrics and the WebSocket is identified here, before any route runs (so no route
can be left open by mistake); pages send whoever is unknown to the login page. Requests that change something,
and every WebSocket, must come from this app's own pages (or an allowed origin) when the browser says where
they come from: another site's page cannot drive the robot through a logged-in operator's browser."""

from __future__ import annotations

from collections.abc import Callable
from urllib.parse import parse_qs, urlsplit

from starlette.responses import JSONResponse, RedirectResponse
from starlette.types import ASGIApp, Receive, Scope, Send

from app.auth.access import COOKIE_NAME, AccessControl
from app.auth.roles import LOCAL_OPERATOR

PUBLIC_PATHS = {"/api/health", "/api/auth/login", "/api/auth/me", "/login"}
# Foxglove and Lichtblick connect from their own origin and cannot set headers: here an API token in the URL is
# the only proof taken (never the login cookie, which another site's page could ride on), whatever the origin.
TOKEN_IN_URL_PATHS = {"/foxglove"}
PAGES = {"/", "/sessions"}
SAFE_METHODS = {"GET", "HEAD", "OPTIONS"}
WS_POLICY_VIOLATION = 1008


def _cookie(headers: dict[bytes, bytes]) -> str | None:
    for part in headers.get(b"cookie", b"").decode("latin-1").split(";"):
        name, _, value = part.strip().partition("=")
        if name == COOKIE_NAME:
            return value
    return None


class AccessMiddleware:
    def __init__(self, app: ASGIApp, access: Callable[[], AccessControl | None], allowed_origins: list[str]) -> None:
        self.app = app
        self.access = access  # looked up per request: the runtime (and its access control) starts in the lifespan
        self.allowed_origins = {o.rstrip("/") for o in allowed_origins}

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        path = scope.get("path", "")
        headers = dict(scope.get("headers", []))
        websocket = scope["type"] == "websocket"
        if path in TOKEN_IN_URL_PATHS:
            await self._by_token_in_url(scope, receive, send, headers)
            return
        if (websocket or scope.get("method") not in SAFE_METHODS) and not self._same_origin(headers):
            await self._refuse(scope, receive, send, 403, "cross-origin request refused (see HUMANOID_ALLOWED_ORIGINS)")
            return
        access = self.access()
        who = (
            LOCAL_OPERATOR
            if access is None
            else access.identify(_cookie(headers), headers.get(b"authorization", b"").decode("latin-1") or None)
        )
        scope.setdefault("state", {})["principal"] = who
        guarded = path.startswith(("/api/", "/ws")) or path == "/metrics"
        if who is None and path not in PUBLIC_PATHS:
            if path in PAGES:
                await RedirectResponse("/login")(scope, receive, send)
                return
            if guarded:
                await self._refuse(scope, receive, send, 401, "log in first (or send Authorization: Bearer <token>)")
                return
        await self.app(scope, receive, send)

    async def _by_token_in_url(self, scope: Scope, receive: Receive, send: Send, headers: dict[bytes, bytes]) -> None:
        query = parse_qs(scope.get("query_string", b"").decode("latin-1"))
        token = (query.get("token") or [""])[0]
        authorization = f"Bearer {token}" if token else headers.get(b"authorization", b"").decode("latin-1") or None
        access = self.access()
        who = LOCAL_OPERATOR if access is None else access.identify(None, authorization)
        if who is None:
            await self._refuse(scope, receive, send, 401, "an API token is needed: ?token=... (humanoid users token)")
            return
        scope.setdefault("state", {})["principal"] = who
        await self.app(scope, receive, send)

    def _same_origin(self, headers: dict[bytes, bytes]) -> bool:
        origin = headers.get(b"origin", b"").decode("latin-1")
        if not origin:
            return True  # not a browser's cross-site request (scripts, curl, same-origin GET)
        if origin.rstrip("/") in self.allowed_origins:
            return True
        host = headers.get(b"host", b"").decode("latin-1")
        return urlsplit(origin).netloc == host

    @staticmethod
    async def _refuse(scope: Scope, receive: Receive, send: Send, status: int, message: str) -> None:
        if scope["type"] == "websocket":
            await send({"type": "websocket.close", "code": WS_POLICY_VIOLATION, "reason": message[:120]})
            return
        await JSONResponse({"detail": {"message": message}}, status_code=status)(scope, receive, send)
