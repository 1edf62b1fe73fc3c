"""Read side of the sessions DB: the list with its filters, one session's timeline, its telemetry."""

from __future__ import annotations

import math
from dataclasses import dataclass
from datetime import datetime
from typing import Any

import numpy as np
from sqlalchemy import Select, and_, exists, func, or_, select
from sqlalchemy.orm import Session

from app.sessions.models import (
    BehaviourRunRow,
    CameraFrameRow,
    CommandRow,
    EventRow,
    PlanRow,
    SessionRow,
    StepResultRow,
    TelemetryChunkRow,
    TranscriptRow,
)
from app.sessions.telemetry_codec import decode_rows
from app.sessions.times import epoch as _ts
from app.sessions.times import iso as _iso
from robot.telemetry import TelemetryLayout

ESTOP_KIND = "estop/latched"
FALL_KIND = "robot/fell"
OUTCOMES = ("succeeded", "failed", "cancelled", "ended", "interrupted", "running")
WARN, ERROR = 1, 2  # robot.interface.Level


@dataclass(frozen=True)
class SessionFilter:
    """What the sessions list may be narrowed to; every field left None matches everything."""

    started_from: datetime | None = None
    started_to: datetime | None = None
    outcome: str | None = None  # one of OUTCOMES
    text: str | None = None  # a word or phrase of any command (case-insensitive)
    had_estop: bool | None = None
    had_fall: bool | None = None
    kind: str | None = None  # serve | run | import

    def apply(self, query: Select) -> Select:
        conditions = []
        if self.started_from is not None:
            conditions.append(SessionRow.started_at >= self.started_from)
        if self.started_to is not None:
            conditions.append(SessionRow.started_at <= self.started_to)
        if self.kind:
            conditions.append(SessionRow.kind == self.kind)
        if self.outcome == "running":
            conditions.append(SessionRow.ended_at.is_(None))
        elif self.outcome == "ended":
            conditions.append(
                and_(SessionRow.ended_at.is_not(None), or_(SessionRow.outcome.is_(None), SessionRow.outcome == "ended"))
            )
        elif self.outcome:
            conditions.append(SessionRow.outcome == self.outcome)
        if self.text:
            pattern = f"%{self.text.lower()}%"
            conditions.append(
                exists().where(CommandRow.session_id == SessionRow.id, func.lower(CommandRow.text).like(pattern))
            )
        for flag, kind in ((self.had_estop, ESTOP_KIND), (self.had_fall, FALL_KIND)):
            if flag is not None:
                has = exists().where(EventRow.session_id == SessionRow.id, EventRow.kind == kind)
                conditions.append(has if flag else ~has)
        return query.where(*conditions) if conditions else query


def _outcome(row: SessionRow) -> str:
    if row.ended_at is None:
        return "running"
    return row.outcome or "ended"


def session_summary(row: SessionRow, counts: dict[str, int] | None = None) -> dict[str, Any]:
    counts = counts or {}
    return {
        "id": row.id,
        "kind": row.kind,
        "started_at": _iso(row.started_at),
        "ended_at": _iso(row.ended_at),
        "seed": row.seed,
        "backend": row.backend,
        "robot_model": row.robot_model,
        "outcome": _outcome(row),
        "summary": row.summary,
        "command_count": counts.get("commands", 0),
        "estop_count": counts.get("estops", 0),
        "fall_count": counts.get("falls", 0),
        "first_command": counts.get("first_command"),
    }


def list_sessions(
    db: Session, filters: SessionFilter | None = None, limit: int = 50, offset: int = 0
) -> tuple[list[dict[str, Any]], int]:
    filters = filters or SessionFilter()
    total = db.scalar(filters.apply(select(func.count(SessionRow.id)))) or 0
    rows = db.scalars(
        filters.apply(select(SessionRow)).order_by(SessionRow.id.desc()).limit(limit).offset(offset)
    ).all()
    ids = [r.id for r in rows]
    counts: dict[int, dict[str, Any]] = {i: {} for i in ids}
    for sid, n in db.execute(
        select(CommandRow.session_id, func.count(CommandRow.id))
        .where(CommandRow.session_id.in_(ids))
        .group_by(CommandRow.session_id)
    ):
        counts[sid]["commands"] = n
    for sid, kind, n in db.execute(
        select(EventRow.session_id, EventRow.kind, func.count(EventRow.id))
        .where(EventRow.session_id.in_(ids), EventRow.kind.in_((ESTOP_KIND, FALL_KIND)))
        .group_by(EventRow.session_id, EventRow.kind)
    ):
        counts[sid]["estops" if kind == ESTOP_KIND else "falls"] = n
    first_ids = select(func.min(CommandRow.id)).where(CommandRow.session_id.in_(ids)).group_by(CommandRow.session_id)
    for sid, text in db.execute(select(CommandRow.session_id, CommandRow.text).where(CommandRow.id.in_(first_ids))):
        counts[sid]["first_command"] = text
    return [session_summary(r, counts[r.id]) for r in rows], total


# ---------------------------------------------------------------------------------------------------------------
# one session


def session_detail(db: Session, session_id: int) -> dict[str, Any] | None:
    """Everything recorded about a session except its telemetry and frames (summarised), with a timeline."""
    row = db.get(SessionRow, session_id)
    if row is None:
        return None
    commands = db.scalars(select(CommandRow).where(CommandRow.session_id == session_id).order_by(CommandRow.id)).all()
    plans = db.scalars(select(PlanRow).where(PlanRow.session_id == session_id).order_by(PlanRow.id)).all()
    steps = db.scalars(
        select(StepResultRow).where(StepResultRow.session_id == session_id).order_by(StepResultRow.id)
    ).all()
    events = db.scalars(select(EventRow).where(EventRow.session_id == session_id).order_by(EventRow.seq)).all()
    transcripts = db.scalars(
        select(TranscriptRow).where(TranscriptRow.session_id == session_id).order_by(TranscriptRow.id)
    ).all()
    steps_by_plan: dict[int, list[dict[str, Any]]] = {}
    for s in steps:
        steps_by_plan.setdefault(s.robot_plan_id, []).append(
            {
                "index": s.step_index,
                "action": s.action,
                "args": s.args,
                "state": s.state,
                "detail": s.detail,
                "sim_start_s": s.sim_start_s,
                "sim_end_s": s.sim_end_s,
                "duration_s": (s.sim_end_s - s.sim_start_s)
                if s.sim_start_s is not None and s.sim_end_s is not None
                else None,
            }
        )
    clock = SimClock.of(events, telemetry_bounds(db, session_id))
    command_list = [
        {
            "id": c.id,
            "robot_command_id": c.robot_command_id,
            "received_at": _iso(c.received_at),
            "sim_time_s": clock.sim_at(c.received_at),
            "source": c.source,
            "text": c.text,
            "accepted": c.accepted,
            "refusal": c.refusal,
            "errors": c.errors,
        }
        for c in commands
    ]
    plan_list = [
        {
            "plan_id": p.robot_plan_id,
            "command_id": p.robot_command_id,
            "revision": p.revision,
            "text": p.text,
            "plan": p.plan,
            "state": p.state,
            "created_at": _iso(p.created_at),
            "finished_at": _iso(p.finished_at),
            "sim_time_s": clock.sim_at(p.created_at),
            "steps": sorted(steps_by_plan.get(p.robot_plan_id, []), key=lambda s: s["index"]),
        }
        for p in plans
    ]
    event_list = [
        {
            "seq": e.seq,
            "kind": e.kind,
            "level": e.level,
            "message": e.message,
            "data": e.data,
            "wall_time": _iso(e.wall_time),
            "sim_time_s": e.sim_time_s,
        }
        for e in events
    ]
    transcript_list = [
        {
            "id": t.id,
            "received_at": _iso(t.received_at),
            "sim_time_s": clock.sim_at(t.received_at),
            "source": t.source,
            "text": t.text,
            "confidence": t.confidence,
            "engine": t.engine,
            "in_grammar": t.in_grammar,
            "audio_s": t.audio_s,
            "decode_ms": t.decode_ms,
            "alternatives": list(t.alternatives or []),
            "audio_url": f"/api/sessions/{session_id}/transcripts/{t.id}/audio.wav" if t.audio_path else None,
        }
        for t in transcripts
    ]
    runs = db.scalars(
        select(BehaviourRunRow).where(BehaviourRunRow.session_id == session_id).order_by(BehaviourRunRow.id)
    ).all()
    behaviour_list = [
        {
            "run_id": r.robot_run_id,
            "command_id": r.robot_command_id,
            "name": r.name,
            "params": r.params,
            "source": r.source,
            "state": r.state,
            "reason": r.reason,
            "feedback": r.feedback or [],
            "started_at": _iso(r.started_at),
            "finished_at": _iso(r.finished_at),
            "sim_start_s": r.sim_start_s,
            "sim_end_s": r.sim_end_s,
        }
        for r in runs
    ]
    counts = {
        "commands": len(commands),
        "estops": sum(e.kind == ESTOP_KIND for e in events),
        "falls": sum(e.kind == FALL_KIND for e in events),
    }
    return {
        **session_summary(row, counts),
        "commands": command_list,
        "plans": plan_list,
        "events": event_list,
        "transcripts": transcript_list,
        "behaviours": behaviour_list,
        "timeline": build_timeline(command_list, transcript_list, plan_list, event_list, session_id),
        "telemetry": telemetry_summary(db, row),
        "camera_frame_count": camera_frame_count(db, session_id),
    }


# What of a behaviour run the timeline shows (its feedback lines are in the run's row, and in the events).
BEHAVIOUR_TIMELINE_KINDS = (
    "behaviour/started",
    "behaviour/state",
    "behaviour/paused",
    "behaviour/resumed",
    "behaviour/snapshot",
    "behaviour/finished",
)


def camera_frame_count(db: Session, session_id: int) -> int:
    return db.scalar(select(func.count(CameraFrameRow.id)).where(CameraFrameRow.session_id == session_id)) or 0


def build_timeline(
    commands: list[dict], transcripts: list[dict], plans: list[dict], events: list[dict], session_id: int | None = None
) -> list[dict[str, Any]]:
    """What happened, in order: commands, what was heard, plans (each revision), step results with timings,
    behaviours (started, their states, what they noticed with the camera's view, how they ended), e-stops, falls,
    errors and alarms. Each item has a `sim_time_s` the replay can seek to."""
    items: list[dict[str, Any]] = []
    for c in commands:
        verdict = "accepted" if c["accepted"] else f"refused ({c['refusal']}): {'; '.join(c['errors'] or [])}"
        items.append(
            {
                "type": "command",
                "at": c["received_at"],
                "sim_time_s": c["sim_time_s"],
                "level": 0,
                "text": f'"{c["text"]}" from {c["source"]}: {verdict}',
            }
        )
    for t in transcripts:
        also = "".join(f', or "{a}"' for a in t["alternatives"])
        items.append(
            {
                "type": "heard",
                "at": t["received_at"],
                "sim_time_s": t["sim_time_s"],
                "level": 0,
                "text": f'heard "{t["text"]}"{also} (confidence {t["confidence"]:.2f}, {t["source"]})',
                "audio_url": t["audio_url"],
            }
        )
    for p in plans:
        actions = ", ".join(s["action"] for s in p["plan"].get("steps", [])) if isinstance(p["plan"], dict) else ""
        text = f'plan {p["plan_id"]} revision {p["revision"]} for "{p["text"]}": {actions} -> {p["state"]}'
        items.append(
            {
                "type": "plan",
                "at": p["created_at"],
                "sim_time_s": p["sim_time_s"],
                "level": 0,
                "text": text,
                "plan_id": p["plan_id"],
            }
        )
    for e in events:
        kind = e["kind"]
        data = e["data"] or {}
        if kind == "plan/step" and data.get("state") in ("succeeded", "failed", "skipped", "cancelled"):
            start, end = data.get("sim_start_s"), data.get("sim_end_s")
            took = f" in {end - start:.1f} s" if start is not None and end is not None else ""
            args = ", ".join(str(v) for v in (data.get("args") or {}).values())
            detail = f": {data['detail']}" if data.get("detail") else ""
            items.append(
                {
                    "type": "step",
                    "at": e["wall_time"],
                    "sim_time_s": start if start is not None else e["sim_time_s"],
                    "level": ERROR if data["state"] == "failed" else 0,
                    "text": f"{data.get('action')}({args}) {data['state']}{took}{detail}",
                    "plan_id": data.get("plan_id"),
                }
            )
        elif kind in BEHAVIOUR_TIMELINE_KINDS:
            item = {
                "type": "behaviour",
                "at": e["wall_time"],
                "sim_time_s": e["sim_time_s"],
                "level": e["level"],
                "text": e["message"],
                "run_id": data.get("run_id"),
            }
            if kind == "behaviour/snapshot" and session_id is not None:
                item["camera_url"] = f"/api/sessions/{session_id}/camera.jpg?t={e['sim_time_s']:.3f}"
            items.append(item)
        elif kind.startswith("estop/"):
            items.append(
                {
                    "type": "estop",
                    "at": e["wall_time"],
                    "sim_time_s": e["sim_time_s"],
                    "level": ERROR,
                    "text": e["message"],
                }
            )
        elif kind == FALL_KIND:
            items.append(
                {
                    "type": "fall",
                    "at": e["wall_time"],
                    "sim_time_s": e["sim_time_s"],
                    "level": ERROR,
                    "text": e["message"],
                }
            )
        elif e["level"] >= WARN and not kind.startswith("plan/"):
            alarm = kind.startswith("diagnostics/") or e["level"] < ERROR
            items.append(
                {
                    "type": "alarm" if alarm else "error",
                    "at": e["wall_time"],
                    "sim_time_s": e["sim_time_s"],
                    "level": e["level"],
                    "text": f"[{kind}] {e['message']}",
                }
            )
    order = {"heard": 0, "command": 1, "plan": 2, "step": 3}
    items.sort(
        key=lambda i: (
            round(i["sim_time_s"], 2) if i["sim_time_s"] is not None else math.inf,
            order.get(i["type"], 4),
            i["at"] or "",
        )
    )
    return items


class SimClock:
    """Simulated time at a wall-clock moment, from pairs the session recorded (events and telemetry chunks)."""

    def __init__(self, walls: np.ndarray, sims: np.ndarray) -> None:
        order = np.argsort(walls, kind="stable")
        self._walls, self._sims = walls[order], sims[order]

    @staticmethod
    def of(events: list[EventRow], bounds: list[tuple[datetime, float]]) -> SimClock:
        pairs = [(_ts(e.wall_time), e.sim_time_s) for e in events] + [(_ts(w), s) for w, s in bounds]
        if not pairs:
            return SimClock(np.zeros(0), np.zeros(0))
        walls, sims = zip(*pairs, strict=True)
        return SimClock(np.array(walls), np.array(sims))

    def sim_at(self, when: datetime | None) -> float | None:
        if when is None or self._walls.size == 0:
            return None
        return round(float(np.interp(_ts(when), self._walls, self._sims)), 3)


def telemetry_bounds(db: Session, session_id: int) -> list[tuple[datetime, float]]:
    chunk = TelemetryChunkRow
    rows = db.execute(
        select(chunk.wall_t0, chunk.sim_t0, chunk.wall_t1, chunk.sim_t1).where(chunk.session_id == session_id)
    ).all()
    return [(w0, s0) for w0, s0, _, _ in rows] + [(w1, s1) for _, _, w1, s1 in rows]


def telemetry_summary(db: Session, row: SessionRow) -> dict[str, Any]:
    count, t0, t1 = db.execute(
        select(
            func.sum(TelemetryChunkRow.count), func.min(TelemetryChunkRow.sim_t0), func.max(TelemetryChunkRow.sim_t1)
        ).where(TelemetryChunkRow.session_id == row.id)
    ).one()
    layout = row.telemetry_layout or {}
    return {
        "samples": int(count or 0),
        "sim_start_s": t0,
        "sim_end_s": t1,
        "duration_s": (t1 - t0) if t0 is not None and t1 is not None else 0.0,
        "rate_hz": row.telemetry_hz,
        "fields": [name for name, _ in layout.get("fields", [])],
        "joint_names": layout.get("joint_names", []),
    }


def load_telemetry(
    db: Session, session_id: int, sim_from: float | None = None, sim_to: float | None = None
) -> tuple[TelemetryLayout | None, np.ndarray]:
    """The session's telemetry rows (n, width) in time order, optionally within [sim_from, sim_to]."""
    row = db.get(SessionRow, session_id)
    if row is None or not row.telemetry_layout:
        return None, np.zeros((0, 0))
    layout = TelemetryLayout.from_json(row.telemetry_layout)
    query = select(TelemetryChunkRow.data).where(TelemetryChunkRow.session_id == session_id)
    if sim_from is not None:
        query = query.where(TelemetryChunkRow.sim_t1 >= sim_from)
    if sim_to is not None:
        query = query.where(TelemetryChunkRow.sim_t0 <= sim_to)
    blobs = db.scalars(query.order_by(TelemetryChunkRow.sim_t0, TelemetryChunkRow.first_seq)).all()
    if not blobs:
        return layout, np.zeros((0, layout.width))
    rows = np.concatenate([decode_rows(b) for b in blobs])
    keep = np.ones(len(rows), dtype=bool)
    if sim_from is not None:
        keep &= rows[:, 0] >= sim_from
    if sim_to is not None:
        keep &= rows[:, 0] <= sim_to
    return layout, rows[keep]


def telemetry_series(
    db: Session,
    session_id: int,
    fields: list[str],
    max_points: int = 2000,
    sim_from: float | None = None,
    sim_to: float | None = None,
) -> dict[str, Any] | None:
    """Named signals for plotting, thinned to at most `max_points` samples (every k-th)."""
    layout, rows = load_telemetry(db, session_id, sim_from, sim_to)
    if layout is None:
        return None
    slices = layout.slices()
    unknown = [f for f in fields if f not in slices]
    if unknown:
        raise KeyError(f"unknown telemetry fields {unknown}; this session has {list(slices)}")
    stride = max(1, int(np.ceil(len(rows) / max_points))) if len(rows) else 1
    thin = rows[::stride]
    out: dict[str, Any] = {"sim_time_s": _finite_list(thin[:, 0]), "stride": stride, "samples": len(rows)}
    for f in fields:
        out[f] = [_finite_list(col) for col in thin[:, slices[f]].T]
    return out


def _finite_list(values: np.ndarray) -> list[float | None]:
    return [round(float(v), 6) if np.isfinite(v) else None for v in values]


def camera_frame_at(db: Session, session_id: int, sim_time_s: float) -> CameraFrameRow | None:
    """The last frame taken at or before `sim_time_s` (the first one before the first)."""
    before = db.scalars(
        select(CameraFrameRow)
        .where(CameraFrameRow.session_id == session_id, CameraFrameRow.sim_time_s <= sim_time_s)
        .order_by(CameraFrameRow.sim_time_s.desc())
        .limit(1)
    ).first()
    if before is not None:
        return before
    return db.scalars(
        select(CameraFrameRow)
        .where(CameraFrameRow.session_id == session_id)
        .order_by(CameraFrameRow.sim_time_s)
        .limit(1)
    ).first()
