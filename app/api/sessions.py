"""Stored sessions."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Depends, HTTPException, Query

from app.api.deps import runtime
from app.runtime import Runtime
from app.sessions.queries import list_sessions, session_detail

router = APIRouter(prefix="/api/sessions", tags=["sessions"])
RuntimeDep = Annotated[Runtime, Depends(runtime)]


@router.get("")
def get_sessions(
    rt: RuntimeDep, limit: Annotated[int, Query(ge=1, le=200)] = 50, offset: Annotated[int, Query(ge=0)] = 0
) -> dict[str, Any]:
    with rt.db() as db:
        items, total = list_sessions(db, limit=limit, offset=offset)
    return {"items": items, "total": total, "limit": limit, "offset": offset}


@router.get("/{session_id}")
def get_session(session_id: int, rt: RuntimeDep) -> dict[str, Any]:
    with rt.db() as db:
        detail = session_detail(db, session_id)
    if detail is None:
        raise HTTPException(status_code=404, detail=f"no session {session_id}")
    return detail
