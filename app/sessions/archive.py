"""A session as one JSON document, and back: for sharing a session, attaching it to a bug report, or moving it to
another database. Everything recorded goes in: the session, commands, transcripts (with their recordings),
plans, step results, events, telemetry and camera frames. Importing it creates a new session (a new id) with the
same content, so exporting the import gives the same document again, ids aside.

The document is written as it is read from the database, chunk by chunk, so a long session never has to sit in
memory as Python objects.
"""

from __future__ import annotations

import base64
import json
from collections.abc import Iterator
from datetime import UTC, datetime
from pathlib import Path
from typing import IO, Any

import numpy as np
from sqlalchemy import select
from sqlalchemy.orm import Session, sessionmaker

from app.sessions.audio_store import recording_file, save_recording
from app.sessions.models import (
    CameraFrameRow,
    CommandRow,
    EventRow,
    PlanRow,
    SessionRow,
    StepResultRow,
    TelemetryChunkRow,
    TranscriptRow,
)
from app.sessions.telemetry_codec import decode_rows, encode_rows
from app.sessions.times import iso as _iso
from app.sessions.times import parse_iso as _when

FORMAT = "humanoid-mission-control/session"
VERSION = 1
IMPORT_CHUNK_ROWS = 32


class ArchiveError(ValueError):
    """A document that is not a session export this version can read, with what is wrong."""


def _row_json(row: np.ndarray) -> str:
    """A telemetry row: times in full, values as float32 holds them, NaN (not measured) as null."""
    parts = [repr(float(row[0])), repr(float(row[1]))]
    parts += ["null" if not np.isfinite(v) else format(float(v), ".9g") for v in row[2:]]
    return "[" + ",".join(parts) + "]"


# ---------------------------------------------------------------------------------------------------------------
# export


def write_session_json(db: Session, session_id: int, out: IO[str], audio_dir: str | None = None) -> None:
    """Write the session as one JSON document to `out`; raises KeyError when there is no such session."""
    row = db.get(SessionRow, session_id)
    if row is None:
        raise KeyError(f"no session {session_id}")
    head = {
        "format": FORMAT,
        "version": VERSION,
        "exported_at": datetime.now(UTC).isoformat(),
        "session": {
            "id": row.id,
            "kind": row.kind,
            "started_at": _iso(row.started_at),
            "ended_at": _iso(row.ended_at),
            "seed": row.seed,
            "backend": row.backend,
            "outcome": row.outcome,
            "summary": row.summary,
            "robot_model": row.robot_model,
            "scene_mjcf": row.scene_mjcf,
            "telemetry_layout": row.telemetry_layout,
            "telemetry_hz": row.telemetry_hz,
        },
    }
    out.write(json.dumps(head)[:-1])  # the document stays open: the sections follow
    sections: list[tuple[str, Iterator[dict[str, Any]]]] = [
        ("commands", _commands(db, session_id)),
        ("transcripts", _transcripts(db, session_id, audio_dir)),
        ("plans", _plans(db, session_id)),
        ("step_results", _steps(db, session_id)),
        ("events", _events(db, session_id)),
        ("camera_frames", _frames(db, session_id)),
    ]
    for name, items in sections:
        out.write(f', "{name}": [')
        for i, item in enumerate(items):
            out.write(("," if i else "") + json.dumps(item))
        out.write("]")
    out.write(', "telemetry": [')
    first = True
    for (blob,) in db.execute(
        select(TelemetryChunkRow.data)
        .where(TelemetryChunkRow.session_id == session_id)
        .order_by(TelemetryChunkRow.sim_t0, TelemetryChunkRow.first_seq)
    ):
        for r in decode_rows(blob):
            out.write(("" if first else ",") + _row_json(r))
            first = False
    out.write("]}")


def _commands(db: Session, sid: int) -> Iterator[dict[str, Any]]:
    for c in db.scalars(select(CommandRow).where(CommandRow.session_id == sid).order_by(CommandRow.id)):
        yield {
            "robot_command_id": c.robot_command_id,
            "received_at": _iso(c.received_at),
            "source": c.source,
            "text": c.text,
            "accepted": c.accepted,
            "refusal": c.refusal,
            "errors": c.errors,
        }


def _transcripts(db: Session, sid: int, audio_dir: str | None) -> Iterator[dict[str, Any]]:
    for t in db.scalars(select(TranscriptRow).where(TranscriptRow.session_id == sid).order_by(TranscriptRow.id)):
        wav = recording_file(audio_dir, t.audio_path) if audio_dir and t.audio_path else None
        yield {
            "received_at": _iso(t.received_at),
            "source": t.source,
            "text": t.text,
            "confidence": t.confidence,
            "engine": t.engine,
            "in_grammar": t.in_grammar,
            "audio_s": t.audio_s,
            "decode_ms": t.decode_ms,
            "alternatives": list(t.alternatives or []),
            "audio_wav_base64": base64.b64encode(wav.read_bytes()).decode() if wav else None,
        }


def _plans(db: Session, sid: int) -> Iterator[dict[str, Any]]:
    for p in db.scalars(select(PlanRow).where(PlanRow.session_id == sid).order_by(PlanRow.id)):
        yield {
            "robot_plan_id": p.robot_plan_id,
            "robot_command_id": p.robot_command_id,
            "revision": p.revision,
            "text": p.text,
            "plan": p.plan,
            "created_at": _iso(p.created_at),
            "state": p.state,
            "finished_at": _iso(p.finished_at),
        }


def _steps(db: Session, sid: int) -> Iterator[dict[str, Any]]:
    for s in db.scalars(select(StepResultRow).where(StepResultRow.session_id == sid).order_by(StepResultRow.id)):
        yield {
            "robot_plan_id": s.robot_plan_id,
            "step_index": s.step_index,
            "action": s.action,
            "args": s.args,
            "state": s.state,
            "detail": s.detail,
            "sim_start_s": s.sim_start_s,
            "sim_end_s": s.sim_end_s,
            "recorded_at": _iso(s.recorded_at),
        }


def _events(db: Session, sid: int) -> Iterator[dict[str, Any]]:
    for e in db.scalars(select(EventRow).where(EventRow.session_id == sid).order_by(EventRow.seq)):
        yield {
            "seq": e.seq,
            "kind": e.kind,
            "level": e.level,
            "message": e.message,
            "data": e.data,
            "wall_time": _iso(e.wall_time),
            "sim_time_s": e.sim_time_s,
        }


def _frames(db: Session, sid: int) -> Iterator[dict[str, Any]]:
    for f in db.scalars(select(CameraFrameRow).where(CameraFrameRow.session_id == sid).order_by(CameraFrameRow.id)):
        yield {
            "seq": f.seq,
            "sim_time_s": f.sim_time_s,
            "wall_time": _iso(f.wall_time),
            "width": f.width,
            "height": f.height,
            "detections": f.detections,
            "jpeg_base64": base64.b64encode(f.jpeg).decode(),
        }


def export_session_json(factory: sessionmaker, session_id: int, path: str | Path, audio_dir: str | None) -> None:
    with factory() as db, open(path, "w", encoding="utf-8") as out:
        write_session_json(db, session_id, out, audio_dir)


# ---------------------------------------------------------------------------------------------------------------
# import


def read_archive(source: str | Path | IO[str] | bytes) -> dict[str, Any]:
    """Parse and check a session document; ArchiveError says what is wrong with it."""
    try:
        if isinstance(source, bytes):
            doc = json.loads(source)
        elif isinstance(source, str | Path):
            with open(source, encoding="utf-8") as f:
                doc = json.load(f)
        else:
            doc = json.load(source)
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ArchiveError(f"not JSON: {exc}") from exc
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise ArchiveError(f'not a session export (its "format" should be "{FORMAT}")')
    if doc.get("version") != VERSION:
        raise ArchiveError(f"session export version {doc.get('version')!r}; this version reads {VERSION}")
    for key in ("session", "commands", "transcripts", "plans", "step_results", "events", "camera_frames", "telemetry"):
        if key not in doc:
            raise ArchiveError(f'the export has no "{key}"')
    return doc


def import_session(factory: sessionmaker, doc: dict[str, Any], audio_dir: str) -> int:
    """Store a checked document (`read_archive`) as a new session; returns its id. All or nothing."""
    s = doc["session"]
    layout = s.get("telemetry_layout")
    width = sum(int(w) for _, w in layout["fields"]) if layout else 0
    try:
        telemetry = np.array([[np.nan if v is None else v for v in r] for r in doc["telemetry"]], dtype=float)
    except (TypeError, ValueError) as exc:
        raise ArchiveError(f"telemetry rows are not numbers: {exc}") from exc
    if len(telemetry) and (telemetry.ndim != 2 or telemetry.shape[1] != width):
        raise ArchiveError(f"telemetry rows have {telemetry.shape[-1]} values; the layout says {width}")
    saved_audio: list[Path] = []
    try:
        with factory() as db:
            row = SessionRow(
                kind="import",
                started_at=_when(s["started_at"]),
                ended_at=_when(s.get("ended_at")),
                seed=int(s["seed"]),
                backend=s.get("backend") or "sim",
                outcome=s.get("outcome") or ("ended" if s.get("ended_at") else "interrupted"),
                summary={**(s.get("summary") or {}), "imported_from": s.get("id"), "original_kind": s.get("kind")},
                robot_model=s.get("robot_model"),
                scene_mjcf=s.get("scene_mjcf"),
                telemetry_layout=layout,
                telemetry_hz=s.get("telemetry_hz"),
                heartbeat_at=_when(s.get("ended_at")),
            )
            if row.ended_at is None:
                row.ended_at = row.started_at
            db.add(row)
            db.flush()
            sid = row.id
            for c in doc["commands"]:
                db.add(
                    CommandRow(
                        session_id=sid,
                        robot_command_id=c.get("robot_command_id"),
                        received_at=_when(c["received_at"]),
                        source=c["source"],
                        text=c["text"],
                        accepted=c["accepted"],
                        refusal=c.get("refusal"),
                        errors=c.get("errors"),
                    )
                )
            for t in doc["transcripts"]:
                path = None
                if t.get("audio_wav_base64"):
                    path = save_recording(audio_dir, sid, base64.b64decode(t["audio_wav_base64"]))
                    saved_audio.append(Path(audio_dir) / path)
                db.add(
                    TranscriptRow(
                        session_id=sid,
                        received_at=_when(t["received_at"]),
                        source=t["source"],
                        text=t["text"],
                        confidence=t["confidence"],
                        engine=t["engine"],
                        in_grammar=t["in_grammar"],
                        audio_s=t["audio_s"],
                        decode_ms=t["decode_ms"],
                        audio_path=path,
                        alternatives=list(t.get("alternatives") or []),  # (archives before stop 59 have none)
                    )
                )
            for p in doc["plans"]:
                db.add(
                    PlanRow(
                        session_id=sid,
                        robot_plan_id=p["robot_plan_id"],
                        robot_command_id=p["robot_command_id"],
                        revision=p["revision"],
                        text=p["text"],
                        plan=p["plan"],
                        created_at=_when(p["created_at"]),
                        state=p["state"],
                        finished_at=_when(p.get("finished_at")),
                    )
                )
            for st in doc["step_results"]:
                db.add(
                    StepResultRow(
                        session_id=sid,
                        robot_plan_id=st["robot_plan_id"],
                        step_index=st["step_index"],
                        action=st["action"],
                        args=st["args"],
                        state=st["state"],
                        detail=st["detail"],
                        sim_start_s=st.get("sim_start_s"),
                        sim_end_s=st.get("sim_end_s"),
                        recorded_at=_when(st["recorded_at"]),
                    )
                )
            for e in doc["events"]:
                db.add(
                    EventRow(
                        session_id=sid,
                        seq=e["seq"],
                        kind=e["kind"],
                        level=e["level"],
                        message=e["message"],
                        data=e.get("data"),
                        wall_time=_when(e["wall_time"]),
                        sim_time_s=e["sim_time_s"],
                    )
                )
            for f in doc["camera_frames"]:
                db.add(
                    CameraFrameRow(
                        session_id=sid,
                        seq=f["seq"],
                        sim_time_s=f["sim_time_s"],
                        wall_time=_when(f["wall_time"]),
                        width=f["width"],
                        height=f["height"],
                        jpeg=base64.b64decode(f["jpeg_base64"]),
                        detections=f.get("detections"),
                    )
                )
            for start in range(0, len(telemetry), IMPORT_CHUNK_ROWS):
                part = telemetry[start : start + IMPORT_CHUNK_ROWS]
                db.add(
                    TelemetryChunkRow(
                        session_id=sid,
                        first_seq=start,
                        count=len(part),
                        sim_t0=float(part[0, 0]),
                        sim_t1=float(part[-1, 0]),
                        wall_t0=datetime.fromtimestamp(part[0, 1], tz=UTC),
                        wall_t1=datetime.fromtimestamp(part[-1, 1], tz=UTC),
                        data=encode_rows(part),
                    )
                )
            db.commit()
            return sid
    except (KeyError, TypeError, ValueError) as exc:
        for path in saved_audio:
            path.unlink(missing_ok=True)
        if isinstance(exc, ArchiveError):
            raise
        raise ArchiveError(f"the export is incomplete or malformed: {exc!r}") from exc
