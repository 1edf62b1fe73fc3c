"""Read side of the sessions DB: what the sessions page and the API show."""

from __future__ import annotations

from typing import Any

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from app.sessions.models import CommandRow, EventRow, PlanRow, SessionRow, StateSampleRow, StepResultRow, TranscriptRow


def _iso(value: Any) -> str | None:
    return value.isoformat() if value is not None else None


def session_summary(row: SessionRow, command_count: int = 0, estops: int = 0) -> dict[str, Any]:
    return {
        "id": row.id,
        "kind": row.kind,
        "started_at": _iso(row.started_at),
        "ended_at": _iso(row.ended_at),
        "seed": row.seed,
        "backend": row.backend,
        "outcome": row.outcome,
        "summary": row.summary,
        "command_count": command_count,
        "estop_count": estops,
    }


def list_sessions(db: Session, limit: int = 50, offset: int = 0) -> tuple[list[dict[str, Any]], int]:
    total = db.scalar(select(func.count(SessionRow.id))) or 0
    rows = db.scalars(select(SessionRow).order_by(SessionRow.id.desc()).limit(limit).offset(offset)).all()
    ids = [r.id for r in rows]
    commands = dict(
        db.execute(
            select(CommandRow.session_id, func.count(CommandRow.id))
            .where(CommandRow.session_id.in_(ids))
            .group_by(CommandRow.session_id)
        ).all()
    )
    estops = dict(
        db.execute(
            select(EventRow.session_id, func.count(EventRow.id))
            .where(EventRow.session_id.in_(ids), EventRow.kind == "estop/latched")
            .group_by(EventRow.session_id)
        ).all()
    )
    return [session_summary(r, commands.get(r.id, 0), estops.get(r.id, 0)) for r in rows], total


def session_detail(db: Session, session_id: int) -> dict[str, Any] | None:
    row = db.get(SessionRow, session_id)
    if row is None:
        return None
    commands = db.scalars(select(CommandRow).where(CommandRow.session_id == session_id).order_by(CommandRow.id))
    plans = db.scalars(select(PlanRow).where(PlanRow.session_id == session_id).order_by(PlanRow.id)).all()
    steps = db.scalars(
        select(StepResultRow).where(StepResultRow.session_id == session_id).order_by(StepResultRow.id)
    ).all()
    events = db.scalars(select(EventRow).where(EventRow.session_id == session_id).order_by(EventRow.seq))
    samples = db.scalar(select(func.count(StateSampleRow.id)).where(StateSampleRow.session_id == session_id))
    transcripts = db.scalars(
        select(TranscriptRow).where(TranscriptRow.session_id == session_id).order_by(TranscriptRow.id)
    ).all()
    steps_by_plan: dict[int, list[dict[str, Any]]] = {}
    for s in steps:
        steps_by_plan.setdefault(s.robot_plan_id, []).append(
            {"index": s.step_index, "action": s.action, "args": s.args, "state": s.state, "detail": s.detail,
             "sim_start_s": s.sim_start_s, "sim_end_s": s.sim_end_s}
        )  # fmt: skip
    event_list = [
        {"seq": e.seq, "kind": e.kind, "level": e.level, "message": e.message, "data": e.data,
         "wall_time": _iso(e.wall_time), "sim_time_s": e.sim_time_s}
        for e in events
    ]  # fmt: skip
    return {
        **session_summary(row, estops=sum(1 for e in event_list if e["kind"] == "estop/latched")),
        "commands": [
            {"id": c.id, "robot_command_id": c.robot_command_id, "received_at": _iso(c.received_at),
             "source": c.source, "text": c.text, "accepted": c.accepted, "refusal": c.refusal, "errors": c.errors}
            for c in commands
        ],
        "plans": [
            {"plan_id": p.robot_plan_id, "command_id": p.robot_command_id, "revision": p.revision, "text": p.text,
             "plan": p.plan, "state": p.state, "created_at": _iso(p.created_at), "finished_at": _iso(p.finished_at),
             "steps": sorted(steps_by_plan.get(p.robot_plan_id, []), key=lambda s: s["index"])}
            for p in plans
        ],
        "events": event_list,
        "transcripts": [
            {"id": t.id, "received_at": _iso(t.received_at), "source": t.source, "text": t.text,
             "confidence": t.confidence, "engine": t.engine, "in_grammar": t.in_grammar, "audio_s": t.audio_s,
             "decode_ms": t.decode_ms,
             "audio_url": f"/api/sessions/{session_id}/transcripts/{t.id}/audio.wav" if t.audio_path else None}
            for t in transcripts
        ],
        "state_sample_count": samples or 0,
    }  # fmt: skip
