"""Keeping the sessions database tidy: sessions a crash left open, deletion, and retention."""

from __future__ import annotations

import logging
import socket
from datetime import UTC, datetime, timedelta

import psutil
from sqlalchemy import delete, func, select
from sqlalchemy.orm import Session, sessionmaker

from app.sessions.audio_store import delete_session_audio
from app.sessions.models import EventRow, SessionRow, TelemetryChunkRow
from app.sessions.times import aware as _aware

log = logging.getLogger(__name__)

# A recorder writes its heartbeat every half second: a session silent this long has no recorder any more.
STALE_AFTER_S = 30.0


def close_interrupted_sessions(
    factory: sessionmaker, now: datetime | None = None, stale_after_s: float = STALE_AFTER_S
) -> list[int]:
    """Sessions still open whose recorder is gone (the server was killed): closed as "interrupted" at the last
    thing recorded. A recorder on this machine is gone when its process is; one elsewhere (another server on a
    shared database) when its heartbeat has been silent for `stale_after_s`."""
    now = now or datetime.now(UTC)
    closed = []
    with factory() as db:
        for row in db.scalars(select(SessionRow).where(SessionRow.ended_at.is_(None))).all():
            last = _last_recorded(db, row)
            if _recorder_alive(row) and now - last < timedelta(seconds=stale_after_s):
                continue
            row.ended_at = last
            row.outcome = "interrupted"
            closed.append(row.id)
        db.commit()
    if closed:
        log.warning("sessions %s were left open by a server that stopped without closing them: interrupted", closed)
    return closed


def _recorder_alive(row: SessionRow) -> bool:
    """False when the process that recorded the session is known to be gone; True when it may still run."""
    if row.recorder_host != socket.gethostname() or row.recorder_pid is None:
        return True  # another machine's: only its heartbeat can tell
    try:
        process = psutil.Process(row.recorder_pid)
        started = datetime.fromtimestamp(process.create_time(), tz=UTC)
    except (psutil.NoSuchProcess, psutil.AccessDenied):
        return False
    # the same pid taken by a later process is not the recorder
    return started <= (_aware(row.started_at) or started) + timedelta(seconds=1)


def _last_recorded(db: Session, row: SessionRow) -> datetime:
    candidates = [
        _aware(row.heartbeat_at),
        _aware(row.started_at),
        _aware(db.scalar(select(func.max(TelemetryChunkRow.wall_t1)).where(TelemetryChunkRow.session_id == row.id))),
        _aware(db.scalar(select(func.max(EventRow.wall_time)).where(EventRow.session_id == row.id))),
    ]
    return max(c for c in candidates if c is not None)


def delete_sessions(factory: sessionmaker, audio_dir: str, session_ids: list[int]) -> int:
    """Delete sessions with everything recorded in them (rows cascade; recordings are removed from disk)."""
    if not session_ids:
        return 0
    with factory() as db:
        deleted = db.execute(delete(SessionRow).where(SessionRow.id.in_(session_ids))).rowcount or 0
        db.commit()
    for sid in session_ids:
        delete_session_audio(audio_dir, sid)
    return deleted


def apply_retention(
    factory: sessionmaker,
    audio_dir: str,
    max_age_days: float,
    max_count: int,
    keep: set[int] | None = None,
    now: datetime | None = None,
) -> list[int]:
    """Delete ended sessions older than `max_age_days` and beyond the newest `max_count` (0 turns either off).
    Sessions in `keep` (the one being recorded) and open ones are never deleted."""
    now = now or datetime.now(UTC)
    keep = keep or set()
    doomed: set[int] = set()
    with factory() as db:
        ended = select(SessionRow.id).where(SessionRow.ended_at.is_not(None))
        if max_age_days > 0:
            cutoff = now - timedelta(days=max_age_days)
            doomed.update(db.scalars(ended.where(SessionRow.started_at < cutoff)).all())
        if max_count > 0:
            newest = db.scalars(select(SessionRow.id).order_by(SessionRow.id.desc()).limit(max_count)).all()
            doomed.update(db.scalars(ended.where(SessionRow.id.not_in(newest))).all())
    doomed -= keep
    if doomed:
        delete_sessions(factory, audio_dir, sorted(doomed))
        log.info("retention deleted %d sessions", len(doomed))
    return sorted(doomed)
