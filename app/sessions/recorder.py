"""Records a session: commands, transcripts, plans, step results, events, telemetry, camera frames, lidar scans
and the occupancy map.

Durability, so that a crash (kill -9 of the server) loses at most the last second of samples and nothing else:
- a command is written before the request that sent it is answered;
- events (and the plans and step results they carry) are written by the recorder thread as soon as they arrive;
- telemetry is drained from the robot continuously and written as a chunk every half second; the session's
  heartbeat goes with it, so the next start can tell a crashed session from a running one.
All writes happen off the control thread; SQLite runs in WAL mode. A write that fails (a locked or full disk) is kept
and retried, never dropped.
"""

from __future__ import annotations

import logging
import os
import queue
import socket
import threading
import time
import zlib
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import UTC, datetime
from typing import Any

import cv2
import numpy as np
from sqlalchemy import update
from sqlalchemy.orm import sessionmaker

from app.sessions.audio_store import keep_recording
from app.sessions.models import (
    BehaviourRunRow,
    CameraFrameRow,
    CommandRow,
    EventRow,
    LidarScanRow,
    OccupancyMapRow,
    PlanRow,
    SessionRow,
    StepResultRow,
    TelemetryChunkRow,
    TranscriptRow,
)
from app.sessions.telemetry_codec import encode_rows
from robot.interface import CommandReply, Event, RobotPort

log = logging.getLogger(__name__)

TELEMETRY_WRITE_S = 0.5  # a chunk per half second: what a crash can lose, plus the write itself
POLL_S = 0.05
TERMINAL_STEP_STATES = {"succeeded", "failed", "skipped", "cancelled"}
MAINTENANCE_PERIOD_S = 300.0
MAX_CHUNK_ROWS = 64  # a headless run makes samples faster than real time: chunks stay small anyway


def shrink_jpeg(jpeg: bytes, width: int, height: int, target_width: int) -> tuple[bytes, int, int, float]:
    """A camera frame re-encoded `target_width` wide (when it is wider): (jpeg, width, height, scale). At 1 Hz a
    640 x 480 frame would be most of what a session stores."""
    if width <= target_width:
        return jpeg, width, height, 1.0
    image = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR)
    if image is None:
        return jpeg, width, height, 1.0
    scale = target_width / width
    small = cv2.resize(image, (target_width, round(height * scale)), interpolation=cv2.INTER_AREA)
    ok, encoded = cv2.imencode(".jpg", small, [cv2.IMWRITE_JPEG_QUALITY, 75])
    if not ok:
        return jpeg, width, height, 1.0
    return encoded.tobytes(), small.shape[1], small.shape[0], scale


def _utc(ts: float | None = None) -> datetime:
    return datetime.fromtimestamp(ts if ts is not None else time.time(), tz=UTC)


@dataclass(frozen=True)
class _PlanFinished:
    robot_plan_id: int
    state: str
    at: datetime


@dataclass(frozen=True)
class _BehaviourFinished:
    robot_run_id: int
    state: str
    reason: str
    feedback: list[str]
    sim_end_s: float
    at: datetime


@dataclass(frozen=True)
class _Heartbeat:
    at: datetime


@dataclass
class WriteStats:
    """What the recorder has written, for `humanoid bench sessions`."""

    commits: int = 0
    rows: int = 0
    telemetry_samples: int = 0
    telemetry_bytes: int = 0
    commit_ms: deque[float] = field(default_factory=lambda: deque(maxlen=10_000))
    last_commit_wall_s: float | None = None
    failing_since_wall_s: float | None = None  # writes fail (a locked DB, a full disk) and are being retried
    last_error: str = ""


class SessionRecorder:
    """One per server run or `humanoid run`: opens a session row, then records until `close()`."""

    def __init__(
        self,
        session_factory: sessionmaker,
        port: RobotPort,
        kind: str,
        seed: int,
        backend: str = "sim",
        audio_dir: str | None = None,
        camera_hz: float = 1.0,
        camera_width: int = 320,
        maintenance: Callable[[int], object] | None = None,
        scan_hz: float = 2.0,
        map_period_s: float = 2.0,
    ) -> None:
        self._factory = session_factory
        self._audio_dir = audio_dir  # where the robot microphone's recordings are moved to, by session
        self._port = port
        self._camera_period = 1.0 / camera_hz if camera_hz > 0 else None
        self._camera_width = camera_width  # frames are stored this wide (a quarter of the pixels of 640 x 480)
        self._scan_period = 1.0 / scan_hz if scan_hz > 0 else None
        self._map_period = map_period_s if map_period_s > 0 else None  # the map when it changed, at most this often
        self._last_scan_time: float | None = None
        self._last_map_scans = -1
        # run with this session's id once the session is open, then every few minutes (given the id: it runs on the
        # recorder's thread, which starts before the constructor returns)
        self._maintenance = maintenance
        self._pending: queue.Queue[Any] = queue.Queue()
        self._write_lock = threading.Lock()  # one writer at a time: the thread, or a command being recorded
        self._stop = threading.Event()
        self._telemetry_rows: list[np.ndarray] = []
        self._telemetry_first_seq = 0
        self._last_camera_seq = -1
        self.telemetry_gaps = 0  # samples the robot had dropped before they could be read (a stalled recorder)
        self.stats = WriteStats()
        description = port.describe()
        with self._factory() as db:
            row = SessionRow(
                kind=kind,
                started_at=_utc(),
                seed=seed,
                backend=backend,
                robot_model=description.model_name,
                scene_mjcf=description.mjcf_xml or None,
                telemetry_layout=description.telemetry_layout or None,
                telemetry_hz=description.telemetry_hz or None,
                heartbeat_at=_utc(),
                recorder_host=socket.gethostname(),
                recorder_pid=os.getpid(),
            )
            db.add(row)
            db.commit()
            self.session_id: int = row.id
        # Telemetry from the moment the session opens (the robot may have run before: that is not this session's).
        self._telemetry_seq = self._first_new_telemetry_seq()
        self._subscription = port.subscribe()
        # Events from before this session opened (the worker starting, its scheduling priority) belong to it too.
        self._history_seq = 0
        for event in port.recent_events():
            self._on_event(event)
            self._history_seq = max(self._history_seq, event.seq)
        self._thread = threading.Thread(target=self._run, name="session-recorder", daemon=True)
        self._thread.start()

    # ----------------------------------------------------------------------------------------------------------

    def record_command(self, text: str, source: str, reply: CommandReply, received_at: float | None = None) -> None:
        """Every command, accepted or refused, with the reasons it was refused: on disk before this returns (or,
        when the database cannot take it now, queued for the next write). `received_at`: when it came (epoch s)."""
        row = CommandRow(
            session_id=self.session_id,
            robot_command_id=reply.command_id,
            received_at=_utc(received_at),
            source=source,
            text=text,
            accepted=reply.accepted,
            refusal=reply.refusal.value if reply.refusal else None,
            errors=list(reply.errors) or None,
        )
        self._pending.put(row)
        self._write_through()

    def record_transcript(self, heard: dict[str, Any], source: str, audio_path: str | None) -> None:
        """What the recogniser heard (`humanoid transcribe`'s fields) and where its recording is kept."""
        self._pending.put(self._transcript_row(heard, source, audio_path, _utc()))
        self._write_through()

    def _write_through(self) -> None:
        """On disk before the caller returns, unless the store is failing now: then the recorder's retries take
        it, and a request does not wait out a locked database each time."""
        if self.stats.failing_since_wall_s is None:
            self._flush()

    def _transcript_row(
        self, heard: dict[str, Any], source: str, audio_path: str | None, at: datetime
    ) -> TranscriptRow:
        return TranscriptRow(
            session_id=self.session_id,
            received_at=at,
            source=source,
            text=heard["text"],
            confidence=heard["confidence"],
            engine=heard["engine"],
            in_grammar=heard["in_grammar"],
            audio_s=heard["audio_s"],
            decode_ms=heard["decode_ms"],
            audio_path=audio_path,
            alternatives=[str(a) for a in heard.get("alternatives") or []],
        )

    def close(self, outcome: str | None = None, summary: dict[str, Any] | None = None) -> None:
        """Flush everything, then mark the session ended (once: a session closed as crashed stays so)."""
        if self._stop.is_set():
            return
        self._stop.set()
        self._thread.join(timeout=10.0)
        self._drain_events()
        self._drain_telemetry()
        self._queue_telemetry_chunk()
        self._flush()
        self._subscription.close()
        with self._write_lock, self._factory() as db:
            db.execute(
                update(SessionRow)
                .where(SessionRow.id == self.session_id)
                .values(ended_at=_utc(), outcome=outcome or "ended", summary=summary, heartbeat_at=_utc())
            )
            db.commit()

    # ----------------------------------------------------------------------------------------------------------

    def _run(self) -> None:
        next_chunk = time.monotonic() + TELEMETRY_WRITE_S
        next_camera = next_scan = next_map = time.monotonic()
        next_maintenance = time.monotonic()
        while not self._stop.is_set():
            event = self._subscription.get(timeout=POLL_S)
            wrote_events = event is not None
            if event is not None:
                self._on_event(event)
                self._drain_events()
            self._drain_telemetry()
            now = time.monotonic()
            if self._camera_period is not None and now >= next_camera:
                self._sample_camera()
                next_camera = now + self._camera_period
            if self._scan_period is not None and now >= next_scan:
                self._sample_scan()
                next_scan = now + self._scan_period
            if self._map_period is not None and now >= next_map:
                self._sample_map()
                next_map = now + self._map_period
            chunk_due = now >= next_chunk or sum(len(r) for r in self._telemetry_rows) >= MAX_CHUNK_ROWS
            if chunk_due:
                self._queue_telemetry_chunk()
                self._pending.put(_Heartbeat(_utc()))
                next_chunk = now + TELEMETRY_WRITE_S
            if wrote_events or chunk_due or not self._pending.empty():
                self._flush()
            if self._maintenance is not None and now >= next_maintenance:
                next_maintenance = now + MAINTENANCE_PERIOD_S
                try:
                    self._maintenance(self.session_id)
                except Exception:
                    log.exception("session maintenance failed")

    def _drain_events(self) -> None:
        while (event := self._subscription.get(timeout=0)) is not None:
            self._on_event(event)

    def _first_new_telemetry_seq(self) -> int:
        batch = self._port.telemetry_since(0)
        return batch.next_seq if batch is not None else 0

    def _drain_telemetry(self) -> None:
        batch = self._port.telemetry_since(self._telemetry_seq)
        if batch is None:
            return
        if batch.first_seq > self._telemetry_seq:
            self.telemetry_gaps += batch.first_seq - self._telemetry_seq
            self._queue_telemetry_chunk()  # a chunk holds consecutive samples only
        if not self._telemetry_rows:
            self._telemetry_first_seq = batch.first_seq
        self._telemetry_rows.append(batch.rows)
        self._telemetry_seq = batch.next_seq

    def _queue_telemetry_chunk(self) -> None:
        if not self._telemetry_rows:
            return
        rows = np.concatenate(self._telemetry_rows)
        self._telemetry_rows = []
        first = self._telemetry_first_seq
        self._telemetry_first_seq += len(rows)
        for start in range(0, len(rows), MAX_CHUNK_ROWS):
            part = rows[start : start + MAX_CHUNK_ROWS]
            self._pending.put(
                TelemetryChunkRow(
                    session_id=self.session_id,
                    first_seq=first + start,
                    count=len(part),
                    sim_t0=float(part[0, 0]),
                    sim_t1=float(part[-1, 0]),
                    wall_t0=_utc(part[0, 1]),
                    wall_t1=_utc(part[-1, 1]),
                    data=encode_rows(part),
                )
            )

    def _sample_camera(self) -> None:
        image = self._port.sensor_feed().camera
        if image is None or image.seq == self._last_camera_seq:
            return
        self._last_camera_seq = image.seq
        jpeg, width, height, scale = shrink_jpeg(image.jpeg, image.width, image.height, self._camera_width)
        detections = [
            {
                "label": d.label,
                "confidence": d.confidence,
                "position": list(d.position),
                "box": [round(v * scale) for v in d.box],
                "distance_m": d.distance_m,
            }
            for d in image.detections
        ]
        self._pending.put(
            CameraFrameRow(
                session_id=self.session_id,
                seq=image.seq,
                sim_time_s=image.sim_time_s,
                wall_time=_utc(),
                width=width,
                height=height,
                jpeg=jpeg,
                detections=detections,
            )
        )

    def _sample_scan(self) -> None:
        scan = self._port.sensor_feed().scan
        if scan is None or scan.sim_time_s == self._last_scan_time:
            return
        self._last_scan_time = scan.sim_time_s
        x, y, yaw = scan.pose
        self._pending.put(
            LidarScanRow(
                session_id=self.session_id,
                sim_time_s=scan.sim_time_s,
                wall_time=_utc(),
                x=x,
                y=y,
                yaw=yaw,
                height_m=scan.height_m,
                angle_min=scan.angle_min,
                angle_increment=scan.angle_increment,
                range_max=scan.range_max,
                ranges=np.asarray(scan.ranges, dtype="<f4").tobytes(),
            )
        )

    def _sample_map(self) -> None:
        grid = self._port.sensor_feed().map
        if grid is None or grid.scans == self._last_map_scans:
            return
        self._last_map_scans = grid.scans
        self._pending.put(
            OccupancyMapRow(
                session_id=self.session_id,
                sim_time_s=grid.sim_time_s,
                wall_time=_utc(),
                resolution=grid.resolution,
                origin_x=grid.origin[0],
                origin_y=grid.origin[1],
                width=grid.width,
                height=grid.height,
                scans=grid.scans,
                data=zlib.compress(grid.data),
            )
        )

    def _on_event(self, event: Event) -> None:
        if event.seq <= self._history_seq:  # already taken from the history
            return
        sid = self.session_id
        data = dict(event.data)
        if event.kind == "speech/heard":  # the robot's microphone: the transcript and its recording
            data["audio_path"] = self._keep(data.get("audio_path"))
            self._pending.put(
                self._transcript_row(data, data.get("source", "robot-mic"), data["audio_path"], _utc(event.wall_time_s))
            )
        elif event.kind == "speech/command":  # ... and the command it ran on hearing it
            self._pending.put(
                CommandRow(
                    session_id=sid,
                    robot_command_id=data.get("command_id"),
                    received_at=_utc(event.wall_time_s),
                    source=data.get("source", "robot-mic"),
                    text=data["text"],
                    accepted=data["accepted"],
                    refusal=data.get("refusal"),
                    errors=data.get("errors") or None,
                )
            )
        self._pending.put(
            EventRow(
                session_id=sid,
                seq=event.seq,
                kind=event.kind,
                level=int(event.level),
                message=event.message,
                data=data or None,
                wall_time=_utc(event.wall_time_s),
                sim_time_s=event.sim_time_s,
            )
        )
        if event.kind == "plan/created":
            self._pending.put(
                PlanRow(
                    session_id=sid,
                    robot_plan_id=data["plan_id"],
                    robot_command_id=data["command_id"],
                    revision=data["revision"],
                    text=data["text"],
                    plan=data["plan"],
                    created_at=_utc(event.wall_time_s),
                    state="running",
                )
            )
        elif event.kind == "plan/step" and data.get("state") in TERMINAL_STEP_STATES:
            self._pending.put(
                StepResultRow(
                    session_id=sid,
                    robot_plan_id=data["plan_id"],
                    step_index=data["index"],
                    action=data["action"],
                    args=data["args"],
                    state=data["state"],
                    detail=data["detail"],
                    sim_start_s=data.get("sim_start_s"),
                    sim_end_s=data.get("sim_end_s"),
                    recorded_at=_utc(event.wall_time_s),
                )
            )
        elif event.kind == "plan/finished":
            self._pending.put(_PlanFinished(data["plan_id"], data["state"], _utc(event.wall_time_s)))
        elif event.kind == "behaviour/started":
            self._pending.put(
                BehaviourRunRow(
                    session_id=sid,
                    robot_run_id=data["run_id"],
                    robot_command_id=data.get("command_id"),
                    name=data["name"],
                    params=data.get("params") or {},
                    source=str(data.get("source", ""))[:16],
                    started_at=_utc(event.wall_time_s),
                    sim_start_s=event.sim_time_s,
                    state="running",
                )
            )
        elif event.kind == "behaviour/finished":
            self._pending.put(
                _BehaviourFinished(
                    data["run_id"],
                    data["state"],
                    data.get("reason", ""),
                    list(data.get("feedback", [])),
                    event.sim_time_s,
                    _utc(event.wall_time_s),
                )
            )
        elif event.kind == "behaviour/snapshot":
            self._sample_camera()  # the view the behaviour reported, kept even between the regular samples

    def _keep(self, spooled: str | None) -> str | None:
        if not spooled or self._audio_dir is None:
            return None
        try:
            return keep_recording(self._audio_dir, self.session_id, spooled)
        except OSError as exc:  # a full disk loses this recording, not the transcript
            log.warning("cannot keep the recording %s: %s", spooled, exc)
            return None

    def backlog(self) -> int:
        """Rows waiting to be written."""
        return self._pending.qsize()

    def _count(self, items: list[Any], seconds: float) -> None:
        stats = self.stats
        stats.commits += 1
        stats.commit_ms.append(seconds * 1e3)
        stats.last_commit_wall_s = time.time()
        stats.failing_since_wall_s = None
        for item in items:
            stats.rows += 1
            if isinstance(item, TelemetryChunkRow):
                stats.telemetry_samples += item.count
                stats.telemetry_bytes += len(item.data)

    def _flush(self) -> None:
        with self._write_lock:
            items = []
            while True:
                try:
                    items.append(self._pending.get_nowait())
                except queue.Empty:
                    break
            if not items:
                return
            started = time.perf_counter()
            try:
                with self._factory() as db:
                    for item in items:
                        if isinstance(item, _PlanFinished):
                            db.flush()
                            db.execute(
                                update(PlanRow)
                                .where(
                                    PlanRow.session_id == self.session_id, PlanRow.robot_plan_id == item.robot_plan_id
                                )
                                .values(state=item.state, finished_at=item.at)
                            )
                        elif isinstance(item, _BehaviourFinished):
                            db.flush()
                            db.execute(
                                update(BehaviourRunRow)
                                .where(
                                    BehaviourRunRow.session_id == self.session_id,
                                    BehaviourRunRow.robot_run_id == item.robot_run_id,
                                )
                                .values(
                                    state=item.state,
                                    reason=item.reason or None,
                                    feedback=item.feedback,
                                    sim_end_s=item.sim_end_s,
                                    finished_at=item.at,
                                )
                            )
                        elif isinstance(item, _Heartbeat):
                            db.execute(
                                update(SessionRow).where(SessionRow.id == self.session_id).values(heartbeat_at=item.at)
                            )
                        else:
                            db.add(item)
                    db.commit()
                self._count(items, time.perf_counter() - started)
            except Exception as exc:  # keep the items, in order, ahead of anything newer: the next flush retries them
                log.exception("session write failed; will retry")
                self.stats.last_error = f"{type(exc).__name__}: {exc}"[:300]
                if self.stats.failing_since_wall_s is None:
                    self.stats.failing_since_wall_s = time.time()
                rest = []
                while True:
                    try:
                        rest.append(self._pending.get_nowait())
                    except queue.Empty:
                        break
                for item in items + rest:
                    self._pending.put(item)
