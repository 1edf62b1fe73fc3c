"""Stored sessions: list and filter, review, delete, export and import, telemetry for plots, and the 3D replay."""

from __future__ import annotations

import os
import pathlib
import tempfile
from datetime import datetime
from typing import Annotated, Any, Literal

from fastapi import APIRouter, BackgroundTasks, Depends, HTTPException, Path, Query, Request, Response
from fastapi.concurrency import run_in_threadpool
from fastapi.responses import FileResponse
from pydantic import BaseModel, ConfigDict, Field

from app.runtime import Runtime
from app.sessions.archive import ArchiveError, export_session_json, import_session, read_archive
from app.sessions.audio_store import recording_file
from app.sessions.maintenance import delete_sessions
from app.sessions.mcap_export import export_session_mcap
from app.sessions.models import SessionRow, TranscriptRow
from app.sessions.queries import (
    OUTCOMES,
    SessionFilter,
    camera_frame_at,
    list_sessions,
    session_detail,
    telemetry_series,
)
from app.viz.replay import ReplayError
from app.web.api.deps import Operator, runtime

router = APIRouter(prefix="/api", tags=["sessions"])
RuntimeDep = Annotated[Runtime, Depends(runtime)]
IMPORT_PATH = "/api/sessions/import"  # (its body limit is larger than the rest)


# A row id as SQL stores it (a larger one is not a row: 422, not the database's overflow)
SQL_INT_MAX = 2**63 - 1
RowId = Annotated[int, Path(ge=1, le=SQL_INT_MAX)]


def _exists(rt: Runtime, session_id: int) -> None:
    with rt.db() as db:
        if db.get(SessionRow, session_id) is None:
            raise HTTPException(status_code=404, detail=f"no session {session_id}")


@router.get("/sessions")
def get_sessions(
    rt: RuntimeDep,
    limit: Annotated[int, Query(ge=1, le=200)] = 50,
    offset: Annotated[int, Query(ge=0, le=SQL_INT_MAX)] = 0,
    started_from: Annotated[datetime | None, Query(alias="from", description="started at or after (ISO 8601)")] = None,
    started_to: Annotated[datetime | None, Query(alias="to", description="started at or before (ISO 8601)")] = None,
    outcome: Annotated[Literal[OUTCOMES] | None, Query()] = None,  # type: ignore[valid-type]
    q: Annotated[str | None, Query(max_length=200, description="text in any of its commands")] = None,
    had_estop: bool | None = None,
    had_fall: bool | None = None,
    kind: Annotated[Literal["serve", "run", "import"] | None, Query()] = None,
) -> dict[str, Any]:
    """Stored sessions, newest first, filtered and paged; `total` counts every match and `live_session_id`
    is the one being recorded."""
    filters = SessionFilter(
        started_from=started_from,
        started_to=started_to,
        outcome=outcome,
        text=q or None,
        had_estop=had_estop,
        had_fall=had_fall,
        kind=kind,
    )
    with rt.db() as db:
        items, total = list_sessions(db, filters, limit=limit, offset=offset)
    return {"items": items, "total": total, "limit": limit, "offset": offset, "live_session_id": rt.recorder.session_id}


@router.get("/sessions/{session_id}")
def get_session(session_id: RowId, rt: RuntimeDep) -> dict[str, Any]:
    """One session: everything recorded but telemetry (commands, transcripts, plans, steps, events) and its
    timeline; 404 when there is none."""
    with rt.db() as db:
        detail = session_detail(db, session_id)
    if detail is None:
        raise HTTPException(status_code=404, detail=f"no session {session_id}")
    detail["live"] = session_id == rt.recorder.session_id
    return detail


@router.delete("/sessions/{session_id}", dependencies=[Operator])
def delete_session(session_id: RowId, rt: RuntimeDep) -> dict[str, Any]:
    """Delete a session and everything recorded in it, its recordings included. The session being recorded now
    cannot be deleted (409)."""
    if session_id == rt.recorder.session_id:
        raise HTTPException(status_code=409, detail="this is the session being recorded now: it cannot be deleted")
    _exists(rt, session_id)
    delete_sessions(rt.db, rt.settings.audio_dir, [session_id])
    return {"deleted": session_id}


@router.get("/sessions/{session_id}/telemetry")
def get_telemetry(
    session_id: RowId,
    rt: RuntimeDep,
    fields: Annotated[str, Query(max_length=300, description="comma-separated, e.g. com,battery_v,tick_ms")],
    max_points: Annotated[int, Query(ge=10, le=20000)] = 2000,
    sim_from: float | None = None,
    sim_to: float | None = None,
) -> dict[str, Any]:
    """Recorded signals over simulated time, thinned to `max_points` samples (every k-th); each field is a list
    of columns (one per joint, axis...), null where not measured."""
    names = [f.strip() for f in fields.split(",") if f.strip()]
    with rt.db() as db:
        try:
            series = telemetry_series(db, session_id, names, max_points, sim_from, sim_to)
        except KeyError as exc:
            raise HTTPException(status_code=422, detail=str(exc.args[0])) from exc
    if series is None:
        raise HTTPException(status_code=404, detail=f"no telemetry for session {session_id}")
    return series


@router.get("/sessions/{session_id}/camera.jpg")
def get_camera_frame(
    session_id: RowId, rt: RuntimeDep, t: Annotated[float, Query(description="sim time (s)")]
) -> Response:
    """The head camera frame recorded at (or last before) simulated time `t`."""
    with rt.db() as db:
        frame = camera_frame_at(db, session_id, t)
        if frame is None:
            raise HTTPException(status_code=404, detail=f"no camera frames recorded in session {session_id}")
        return Response(frame.jpeg, media_type="image/jpeg", headers={"X-Sim-Time": f"{frame.sim_time_s:.3f}"})


@router.get("/sessions/{session_id}/transcripts/{transcript_id}/audio.wav")
def get_recording(session_id: RowId, transcript_id: RowId, rt: RuntimeDep) -> FileResponse:
    """The recording a transcript was made from; 404 when there is none (or it has been deleted)."""
    with rt.db() as db:
        row = db.get(TranscriptRow, transcript_id)
    if row is None or row.session_id != session_id or row.audio_path is None:
        raise HTTPException(status_code=404, detail=f"no recording for transcript {transcript_id}")
    path = recording_file(rt.settings.audio_dir, row.audio_path)
    if path is None:
        raise HTTPException(status_code=404, detail=f"the recording of transcript {transcript_id} is gone")
    return FileResponse(path, media_type="audio/wav")


@router.get("/sessions/{session_id}/export")
async def export_session(
    session_id: RowId, rt: RuntimeDep, background: BackgroundTasks, format: Literal["json", "mcap"] = "json"
) -> FileResponse:
    """The session as one JSON document (importable again) or as MCAP with Foxglove schemas (Foxglove, Lichtblick)."""
    await run_in_threadpool(_exists, rt, session_id)
    descriptor, name = tempfile.mkstemp(prefix=f"session-{session_id}-", suffix=f".{format}")
    os.close(descriptor)
    path = pathlib.Path(name)
    background.add_task(path.unlink, missing_ok=True)
    if format == "json":
        await run_in_threadpool(export_session_json, rt.db, session_id, path, rt.settings.audio_dir)
        media = "application/json"
    else:
        await run_in_threadpool(export_session_mcap, rt.db, session_id, path)
        media = "application/octet-stream"
    return FileResponse(path, media_type=media, filename=f"session-{session_id}.{format}", background=background)


@router.post("/sessions/import", status_code=201, dependencies=[Operator])
async def import_session_json(request: Request, rt: RuntimeDep) -> dict[str, Any]:
    """A session exported as JSON (by this API or `humanoid sessions export`) stored as a new session."""
    body = await request.body()
    try:
        doc = read_archive(body)
        new_id = await run_in_threadpool(import_session, rt.db, doc, rt.settings.audio_dir)
    except ArchiveError as exc:
        raise HTTPException(status_code=422, detail=str(exc)) from exc
    return {"session_id": new_id}


# ---------------------------------------------------------------------------------------------------------------
# replay


class ReplayIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    session_id: int = Field(ge=1, le=SQL_INT_MAX)
    sim_time_s: float | None = Field(None, allow_inf_nan=False)


class SeekIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    sim_time_s: float = Field(allow_inf_nan=False)


class PlayIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    speed: float | None = Field(None, gt=0, le=16, allow_inf_nan=False)


def _replay(rt: Runtime) -> Any:
    if rt.replay is None:
        raise HTTPException(status_code=503, detail="the replay's 3D view is disabled on this server")
    return rt.replay


def _replay_call(call: Any, *args: Any) -> dict[str, Any]:
    try:
        return call(*args).as_dict()
    except ReplayError as exc:
        raise HTTPException(status_code=409 if "loaded" in str(exc) else 404, detail=str(exc)) from exc


@router.get("/replay")
def replay_status(rt: RuntimeDep) -> dict[str, Any]:
    """What the replay's 3D view shows: the session, its time and span, playing or paused, the speed, and the
    timeline entry in force."""
    return _replay(rt).status().as_dict()


@router.post("/replay")
def replay_load(body: ReplayIn, rt: RuntimeDep) -> dict[str, Any]:
    """Show a session in the replay's 3D view, paused at `sim_time_s` (or its start)."""
    return _replay_call(_replay(rt).load, body.session_id, body.sim_time_s)


@router.post("/replay/seek")
def replay_seek(body: SeekIn, rt: RuntimeDep) -> dict[str, Any]:
    """Move the replay to `sim_time_s` of its session."""
    return _replay_call(_replay(rt).seek, body.sim_time_s)


@router.post("/replay/play")
def replay_play(rt: RuntimeDep, body: PlayIn | None = None) -> dict[str, Any]:
    """Play the replay from where it is, at `speed` times real time (optional)."""
    return _replay_call(_replay(rt).play, body.speed if body else None)


@router.post("/replay/pause")
def replay_pause(rt: RuntimeDep) -> dict[str, Any]:
    """Pause the replay where it is."""
    return _replay_call(_replay(rt).pause)
