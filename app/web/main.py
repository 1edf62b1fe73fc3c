"""FastAPI application factory. The lifespan starts the robot worker, the mirror and the session recorder."""

from __future__ import annotations

import gc
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import FileResponse, JSONResponse
from fastapi.staticfiles import StaticFiles
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from app.auth.middleware import AccessMiddleware
from app.foxglove import proxy as foxglove_proxy
from app.runtime import Runtime
from app.settings import REPO_ROOT, Settings, get_settings
from app.web.api import auth, behaviours, diagnostics, perception, robot, scene, sessions, speech
from app.web.relay_priority import raise_relay_priority
from app.web.ws import router as ws_router

STATIC_DIR = REPO_ROOT / "static"


class BodySizeLimit:
    """Refuse request bodies over `max_bytes` with 413, whether or not Content-Length is declared."""

    def __init__(self, app: ASGIApp, max_bytes: int, larger: dict[str, int] | None = None) -> None:
        self.app = app
        self.max_bytes = max_bytes
        self.larger = larger or {}  # path -> its own limit (recordings are bigger than commands)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        limit = self.larger.get(scope.get("path", ""), self.max_bytes)
        declared = dict(scope.get("headers", [])).get(b"content-length")
        if declared is not None and declared.isdigit() and int(declared) > limit:
            await self._reject(scope, receive, send, limit)
            return
        seen = 0

        async def limited_receive() -> Message:
            nonlocal seen
            message = await receive()
            if message["type"] == "http.request":
                seen += len(message.get("body", b""))
                if seen > limit:
                    raise _TooLarge()
            return message

        try:
            await self.app(scope, limited_receive, send)
        except _TooLarge:
            await self._reject(scope, receive, send, limit)

    async def _reject(self, scope: Scope, receive: Receive, send: Send, limit: int) -> None:
        response = JSONResponse({"detail": f"request body larger than {limit} bytes"}, status_code=413)
        await response(scope, receive, send)


class _TooLarge(Exception):
    pass


async def _validation_error(request: Request, exc: Exception) -> JSONResponse:
    """422 with where and why, without echoing the input (it may be huge, or NaN, which JSON cannot carry)."""
    assert isinstance(exc, RequestValidationError)
    errors = [{"loc": list(e["loc"]), "msg": e["msg"], "type": e["type"]} for e in exc.errors()]
    return JSONResponse({"detail": errors}, status_code=422)


def settle_garbage_collector() -> None:
    """Everything built at start-up (models, 3D scenes, modules) is set aside from the garbage collector.

    Why: a full collection scanned all of it: 256-294 ms with every thread stopped, three times in 40 s under 20
    viewers (measured with a gc callback during `humanoid bench load`), and the e-stop waited that long."""
    gc.collect()
    gc.freeze()


def create_app(
    settings: Settings | None = None, runtime: Runtime | None = None, relay_priority: bool = False
) -> FastAPI:
    """The app. Pass `runtime` to serve an already-started robot (tests); otherwise the lifespan starts one.
    `relay_priority`: run the event loop (the e-stop's relay) at a real-time priority (`humanoid serve` does)."""
    settings = settings or get_settings()

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        owned = runtime is None
        app.state.runtime = runtime or Runtime.start(settings)
        if owned:
            settle_garbage_collector()
        app.state.relay_priority = raise_relay_priority() if relay_priority else "normal priority (not asked for)"
        try:
            yield
        finally:
            speech.close_recognizers()
            if owned:
                app.state.runtime.stop()

    app = FastAPI(
        title="Humanoid mission control",
        version="0.1.0",
        description="Commands, plans, e-stop, state and sessions of a simulated (or real) Robotis OP3.",
        lifespan=lifespan,
    )
    app.add_middleware(
        BodySizeLimit,
        max_bytes=settings.max_body_bytes,
        larger={"/api/speech/transcribe": speech.MAX_AUDIO_BYTES, sessions.IMPORT_PATH: settings.max_import_bytes},
    )
    app.add_middleware(
        AccessMiddleware,
        access=lambda: getattr(getattr(app.state, "runtime", None), "access", None),
        allowed_origins=settings.allowed_origins,
    )
    app.add_exception_handler(RequestValidationError, _validation_error)
    app.include_router(auth.router)
    app.include_router(robot.router)
    app.include_router(behaviours.router)
    app.include_router(perception.router)
    app.include_router(scene.router)
    app.include_router(sessions.router)
    app.include_router(speech.router)
    app.include_router(diagnostics.router)
    app.include_router(ws_router)
    app.include_router(foxglove_proxy.router)
    app.mount("/static", StaticFiles(directory=STATIC_DIR), name="static")

    @app.get("/", include_in_schema=False)
    def index() -> FileResponse:
        return FileResponse(STATIC_DIR / "index.html", headers={"Cache-Control": "no-cache"})

    @app.get("/login", include_in_schema=False)
    def login_page() -> FileResponse:
        return FileResponse(STATIC_DIR / "login.html", headers={"Cache-Control": "no-cache"})

    @app.get("/sessions", include_in_schema=False)
    def sessions_page(request: Request) -> FileResponse:
        return FileResponse(STATIC_DIR / "sessions.html", headers={"Cache-Control": "no-cache"})

    return app
