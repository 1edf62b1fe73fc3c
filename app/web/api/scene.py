"""What a page needs to open the 3D views: a token of its own login (see `app.auth.scene_tokens`), their ports,
and a second name of this server to open them on.

Why a second name: browsers isolate by site (host name), not port. A 3D view on the page's own site renders in
the page's process, and its software WebGL then delays the e-stop; on another name for the same server
(localhost for 127.0.0.1, the IP address for a host name, and the other way round) it gets a process of its own.
"""

from __future__ import annotations

import ipaddress
import socket
import time
from typing import Annotated, Any

from fastapi import APIRouter, Depends, Request

from app.auth.access import COOKIE_NAME, LOGIN_TTL_S
from app.auth.roles import Principal
from app.auth.scene_tokens import login_id
from app.runtime import Runtime
from app.web.api.deps import principal, runtime

router = APIRouter(prefix="/api", tags=["3d views"])
RuntimeDep = Annotated[Runtime, Depends(runtime)]
PrincipalDep = Annotated[Principal, Depends(principal)]
LOCAL_LOGIN = "local"  # everyone, when access control is off (loopback only)


def credential_of(request: Request) -> str:
    """The login the request proved itself with, as the access middleware took it (a token first)."""
    authorization = request.headers.get("authorization", "")
    if authorization.lower().startswith("bearer "):
        return authorization[7:].strip()
    return request.cookies.get(COOKIE_NAME) or LOCAL_LOGIN


def other_site(hostname: str, local_address: str) -> str:
    """Another name for this server than `hostname` (what the page was opened with), as it goes in a URL."""
    if hostname == "127.0.0.1":
        return "localhost"
    if hostname == "localhost":
        return "127.0.0.1"
    try:
        ipaddress.ip_address(hostname.strip("[]"))
    except ValueError:  # a name: the address the browser reached us at
        return f"[{local_address}]" if ":" in local_address else local_address
    return socket.gethostname()  # an address: our name (the page checks that the browser can resolve it)


@router.get("/scene")
def scene(request: Request, rt: RuntimeDep, who: PrincipalDep) -> dict[str, Any]:
    """A token for the 3D views (valid while this login is, at most 12 h), their ports (null: off), and the host
    name to open them on so that they render apart from the page. Open `<scheme>://<host>:<port>/s/<token>/`."""
    credential = credential_of(request)
    expires_at = time.time() + LOGIN_TTL_S
    if rt.access is not None and rt.access.enabled and credential == request.cookies.get(COOKIE_NAME):
        expires_at = rt.access.login_expiry(credential) or expires_at
    local_address = request.scope.get("server", ("127.0.0.1", 0))[0]
    return {
        "token": rt.scene_tokens.issue(who, login_id(credential), expires_at),
        "expires_at": expires_at,
        "ports": {view: rt.scene_port(view) for view in ("full", "light", "replay")},
        "host": other_site(request.url.hostname or "127.0.0.1", local_address),
    }
