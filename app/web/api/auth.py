"""Login, logout, who am I, and the control lock (who operates now; taking it over)."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Depends, HTTPException, Request, Response
from pydantic import BaseModel, ConfigDict, Field

from app.auth.access import COOKIE_NAME, LOGIN_TTL_S, LoginThrottled
from app.auth.control import ControlHeld
from app.auth.roles import Principal, Role
from app.auth.scene_tokens import login_id
from app.runtime import Runtime
from app.web.api.deps import principal, runtime
from app.web.robot_calls import ask
from robot.interface import PauseBehaviour

router = APIRouter(prefix="/api", tags=["access"])
RuntimeDep = Annotated[Runtime, Depends(runtime)]
PrincipalDep = Annotated[Principal, Depends(principal)]


class LoginIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    name: str = Field(min_length=1, max_length=64)
    password: str = Field(min_length=1, max_length=256)


class TakeControlIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    take_over: bool = Field(False, description="take control from the operator who has it (they are told)")


def control_json(rt: Runtime) -> dict[str, Any]:
    holder = rt.control.holder
    return {"holder": holder.name if holder else None, "since": holder.since if holder else None}


@router.post("/auth/login")
def login(body: LoginIn, request: Request, response: Response, rt: RuntimeDep) -> dict[str, Any]:
    """Sets the login cookie (HttpOnly, SameSite=Strict; 12 h). 401 for a wrong name or password, 429 after five
    wrong ones in a row (for that name, or from that address) for 30 s."""
    if rt.access is None or not rt.access.enabled:
        return {"name": "local", "role": Role.OPERATOR.value, "auth": False}
    client = request.client.host if request.client else "?"
    try:
        result = rt.access.login(body.name, body.password, client)
    except LoginThrottled as exc:
        raise HTTPException(
            429, detail={"message": str(exc)}, headers={"Retry-After": str(int(exc.retry_after_s) + 1)}
        ) from exc
    if result is None:
        raise HTTPException(401, detail={"message": "wrong name or password"})
    who, cookie = result
    response.set_cookie(
        COOKIE_NAME, cookie, max_age=LOGIN_TTL_S, httponly=True, samesite="strict", secure=request.url.scheme == "https"
    )
    return {"name": who.name, "role": who.role.value, "auth": True}


@router.post("/auth/logout")
def logout(request: Request, response: Response, rt: RuntimeDep) -> dict[str, Any]:
    """Ends this login: its cookie, and its 3D views (their token is refused, their viewers disconnected)."""
    cookie = request.cookies.get(COOKIE_NAME)
    if rt.access is not None:
        rt.access.logout(cookie)
    if cookie:
        rt.end_scene_login(login_id(cookie))
    response.delete_cookie(COOKIE_NAME)
    return {"logged_out": True}


@router.get("/auth/me")
def me(request: Request, rt: RuntimeDep) -> dict[str, Any]:
    """Who the caller is (401 if nobody, when access control is on), their role and who has control."""
    who = getattr(request.state, "principal", None)
    if who is None:
        raise HTTPException(401, detail={"message": "log in first", "auth": True})
    enabled = rt.access is not None and rt.access.enabled
    return {"name": who.name, "role": who.role.value, "auth": enabled, "control": control_json(rt)}


@router.get("/control")
def control(rt: RuntimeDep, _: PrincipalDep) -> dict[str, Any]:
    """Who holds control (`holder`: a name, or null when nobody does) and since when."""
    return control_json(rt)


@router.post("/control/take")
async def take_control(body: TakeControlIn, rt: RuntimeDep, who: PrincipalDep) -> dict[str, Any]:
    """An operator takes control: free, theirs already, or (with take_over) from another operator. 409 when
    another operator has it and take_over is false; 403 for a viewer. Taken over from another operator, a running
    behaviour pauses (the new operator resumes it, or not)."""
    if not who.role.allows(Role.OPERATOR):
        raise HTTPException(403, detail={"message": "only an operator can take control"})
    previous = rt.control.holder
    try:
        rt.control.take(who, body.take_over)
    except ControlHeld as exc:
        raise HTTPException(409, detail={"message": str(exc), "holder": exc.holder.name}) from exc
    if previous is not None and previous.name != who.name:
        await ask(rt.worker, PauseBehaviour(f"paused: {who.name} took control over from {previous.name}"))
    return control_json(rt)


@router.post("/control/release")
def release_control(rt: RuntimeDep, who: PrincipalDep) -> dict[str, Any]:
    """Give control back (anyone's page shows it free); 409 when the caller does not have it."""
    if not rt.control.release(who):
        raise HTTPException(409, detail={"message": "you do not have control"})
    return control_json(rt)
