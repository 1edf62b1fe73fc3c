"""Records a session: commands, plans, step results, events and state samples, written in batches by one
background thread so neither the control loop nor a web request ever waits for the disk."""

from __future__ import annotations

import logging
import queue
import threading
import time
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Any

from sqlalchemy import update
from sqlalchemy.orm import sessionmaker

from app.sessions.audio_store import keep_recording
from app.sessions.models import (
    CommandRow,
    EventRow,
    PlanRow,
    SessionRow,
    StateSampleRow,
    StepResultRow,
    TranscriptRow,
)
from robot.interface import CommandReply, Event, RobotPort

log = logging.getLogger(__name__)

FLUSH_INTERVAL_S = 0.25
TERMINAL_STEP_STATES = {"succeeded", "failed", "skipped", "cancelled"}


def _utc(ts: float | None = None) -> datetime:
    return datetime.fromtimestamp(ts if ts is not None else time.time(), tz=UTC)


@dataclass(frozen=True)
class _PlanFinished:
    robot_plan_id: int
    state: str
    at: datetime


class SessionRecorder:
    """One per server run or `humanoid run`: opens a session row, then records until `close()`."""

    def __init__(
        self,
        session_factory: sessionmaker,
        port: RobotPort,
        kind: str,
        seed: int,
        backend: str = "sim",
        sample_hz: float = 10.0,
        audio_dir: str | None = None,
    ) -> None:
        self._factory = session_factory
        self._audio_dir = audio_dir  # where the robot microphone's recordings are moved to, by session
        self._port = port
        self._sample_period = 1.0 / sample_hz
        self._pending: queue.Queue[Any] = queue.Queue()
        self._stop = threading.Event()
        with self._factory() as db:
            row = SessionRow(kind=kind, started_at=_utc(), seed=seed, backend=backend)
            db.add(row)
            db.commit()
            self.session_id: int = row.id
        self._subscription = port.subscribe()
        # Events from before this session opened (the worker starting, its scheduling priority) belong to it too.
        self._history_seq = 0
        for event in port.recent_events():
            self._on_event(event)
            self._history_seq = max(self._history_seq, event.seq)
        self._thread = threading.Thread(target=self._run, name="session-recorder", daemon=True)
        self._thread.start()

    # ----------------------------------------------------------------------------------------------------------

    def record_command(self, text: str, source: str, reply: CommandReply) -> None:
        """Every command, accepted or refused, with the reasons it was refused."""
        self._pending.put(
            CommandRow(
                session_id=self.session_id,
                robot_command_id=reply.command_id,
                received_at=_utc(),
                source=source,
                text=text,
                accepted=reply.accepted,
                refusal=reply.refusal.value if reply.refusal else None,
                errors=list(reply.errors) or None,
            )
        )

    def record_transcript(self, heard: dict[str, Any], source: str, audio_path: str | None) -> None:
        """What the recogniser heard (`humanoid transcribe`'s fields) and where its recording is kept."""
        self._pending.put(
            TranscriptRow(session_id=self.session_id, received_at=_utc(), source=source, text=heard["text"],
                          confidence=heard["confidence"], engine=heard["engine"], in_grammar=heard["in_grammar"],
                          audio_s=heard["audio_s"], decode_ms=heard["decode_ms"], audio_path=audio_path)
        )  # fmt: skip

    def close(self, outcome: str | None = None, summary: dict[str, Any] | None = None) -> None:
        """Flush everything, then mark the session ended."""
        self._stop.set()
        self._thread.join(timeout=10.0)
        self._drain_events()
        self._flush()
        self._subscription.close()
        with self._factory() as db:
            db.execute(
                update(SessionRow)
                .where(SessionRow.id == self.session_id)
                .values(ended_at=_utc(), outcome=outcome, summary=summary)
            )
            db.commit()

    # ----------------------------------------------------------------------------------------------------------

    def _run(self) -> None:
        next_sample = time.monotonic()
        next_flush = time.monotonic() + FLUSH_INTERVAL_S
        while not self._stop.is_set():
            event = self._subscription.get(timeout=0.02)
            if event is not None:
                self._on_event(event)
                self._drain_events()
            now = time.monotonic()
            if now >= next_sample:
                self._sample()
                next_sample = now + self._sample_period
            if now >= next_flush:
                self._flush()
                next_flush = now + FLUSH_INTERVAL_S

    def _drain_events(self) -> None:
        while (event := self._subscription.get(timeout=0)) is not None:
            self._on_event(event)

    def _on_event(self, event: Event) -> None:
        if event.seq <= self._history_seq:  # already taken from the history
            return
        sid = self.session_id
        data = dict(event.data)
        if event.kind == "speech/heard":  # the robot's microphone: the transcript and its recording
            data["audio_path"] = self._keep(data.get("audio_path"))
            self.record_transcript(data, data.get("source", "robot-mic"), data["audio_path"])
        elif event.kind == "speech/command":  # ... and the command it ran on hearing it
            self._pending.put(
                CommandRow(session_id=sid, robot_command_id=data.get("command_id"), received_at=_utc(event.wall_time_s),
                           source=data.get("source", "robot-mic"), text=data["text"], accepted=data["accepted"],
                           refusal=data.get("refusal"), errors=data.get("errors") or None)
            )  # fmt: skip
        self._pending.put(
            EventRow(session_id=sid, seq=event.seq, kind=event.kind, level=int(event.level), message=event.message,
                     data=data or None, wall_time=_utc(event.wall_time_s), sim_time_s=event.sim_time_s)
        )  # fmt: skip
        if event.kind == "plan/created":
            self._pending.put(
                PlanRow(session_id=sid, robot_plan_id=data["plan_id"], robot_command_id=data["command_id"],
                        revision=data["revision"], text=data["text"], plan=data["plan"],
                        created_at=_utc(event.wall_time_s), state="running")
            )  # fmt: skip
        elif event.kind == "plan/step" and data.get("state") in TERMINAL_STEP_STATES:
            self._pending.put(
                StepResultRow(session_id=sid, robot_plan_id=data["plan_id"], step_index=data["index"],
                              action=data["action"], args=data["args"], state=data["state"], detail=data["detail"],
                              sim_start_s=data.get("sim_start_s"), sim_end_s=data.get("sim_end_s"),
                              recorded_at=_utc(event.wall_time_s))
            )  # fmt: skip
        elif event.kind == "plan/finished":
            self._pending.put(_PlanFinished(data["plan_id"], data["state"], _utc(event.wall_time_s)))

    def _keep(self, spooled: str | None) -> str | None:
        if not spooled or self._audio_dir is None:
            return None
        try:
            return keep_recording(self._audio_dir, self.session_id, spooled)
        except OSError as exc:  # a full disk loses this recording, not the transcript
            log.warning("cannot keep the recording %s: %s", spooled, exc)
            return None

    def _sample(self) -> None:
        s = self._port.state()
        x, y, z = s.base_position
        self._pending.put(
            StateSampleRow(session_id=self.session_id, wall_time=_utc(s.wall_time_s), sim_time_s=s.sim_time_s,
                           mode=s.mode.value, x=x, y=y, z=z, yaw_rad=s.base_yaw_rad, tilt_deg=s.tilt_deg,
                           qpos=list(s.qpos))
        )  # fmt: skip

    def _flush(self) -> None:
        items = []
        while True:
            try:
                items.append(self._pending.get_nowait())
            except queue.Empty:
                break
        if not items:
            return
        try:
            with self._factory() as db:
                for item in items:
                    if isinstance(item, _PlanFinished):
                        db.flush()
                        db.execute(
                            update(PlanRow)
                            .where(PlanRow.session_id == self.session_id, PlanRow.robot_plan_id == item.robot_plan_id)
                            .values(state=item.state, finished_at=item.at)
                        )
                    else:
                        db.add(item)
                db.commit()
        except Exception:  # keep the items: the next flush retries them
            log.exception("session write failed; will retry")
            for item in items:
                self._pending.put(item)
