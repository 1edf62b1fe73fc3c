"""Stored sessions."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Depends, HTTPException, Query
from fastapi.responses import FileResponse

from app.api.deps import runtime
from app.runtime import Runtime
from app.sessions.audio_store import recording_file
from app.sessions.models import TranscriptRow
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


@router.get("/{session_id}/transcripts/{transcript_id}/audio.wav")
def get_recording(session_id: int, transcript_id: int, rt: RuntimeDep) -> FileResponse:
    """The recording a transcript was made from; 404 when there is none (or it has been deleted)."""
    with rt.db() as db:
        row = db.get(TranscriptRow, transcript_id)
    if row is None or row.session_id != session_id or row.audio_path is None:
        raise HTTPException(status_code=404, detail=f"no recording for transcript {transcript_id}")
    path = recording_file(rt.settings.audio_dir, row.audio_path)
    if path is None:
        raise HTTPException(status_code=404, detail=f"the recording of transcript {transcript_id} is gone")
    return FileResponse(path, media_type="audio/wav")
