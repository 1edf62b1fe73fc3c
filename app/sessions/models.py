"""SQLAlchemy 2 models of sessions. The schema is created by alembic migrations, never by create_all."""

from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy import JSON, Boolean, DateTime, Float, ForeignKey, Index, Integer, LargeBinary, String, Text
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column, relationship


class Base(DeclarativeBase):
    pass


class SessionRow(Base):
    __tablename__ = "sessions"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    kind: Mapped[str] = mapped_column(String(16))  # "serve" | "run"
    started_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), index=True)
    ended_at: Mapped[datetime | None] = mapped_column(DateTime(timezone=True))
    seed: Mapped[int] = mapped_column(Integer)
    backend: Mapped[str] = mapped_column(String(32))
    # succeeded | failed | cancelled | ended | interrupted (the server died: found open at the next start) | None (open)
    outcome: Mapped[str | None] = mapped_column(String(16))
    summary: Mapped[dict[str, Any] | None] = mapped_column(JSON)
    robot_model: Mapped[str | None] = mapped_column(String(64))
    scene_mjcf: Mapped[str | None] = mapped_column(Text)  # the robot and its world as simulated (for replay, export)
    # robot.telemetry.TelemetryLayout.to_json(): the columns of this session's telemetry chunks, and their rate
    telemetry_layout: Mapped[dict[str, Any] | None] = mapped_column(JSON)
    telemetry_hz: Mapped[float | None] = mapped_column(Float)
    heartbeat_at: Mapped[datetime | None] = mapped_column(DateTime(timezone=True))  # the recorder's last write
    recorder_host: Mapped[str | None] = mapped_column(String(255))  # which process records it (while open)
    recorder_pid: Mapped[int | None] = mapped_column(Integer)

    commands: Mapped[list[CommandRow]] = relationship(back_populates="session", cascade="all, delete-orphan")


class CommandRow(Base):
    __tablename__ = "commands"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    session_id: Mapped[int] = mapped_column(ForeignKey("sessions.id", ondelete="CASCADE"), index=True)
    robot_command_id: Mapped[int | None] = mapped_column(Integer)
    received_at: Mapped[datetime] = mapped_column(DateTime(timezone=True))
    source: Mapped[str] = mapped_column(String(16))
    text: Mapped[str] = mapped_column(Text)
    accepted: Mapped[bool] = mapped_column(Boolean)
    refusal: Mapped[str | None] = mapped_column(String(32))
    errors: Mapped[list[str] | None] = mapped_column(JSON)

    session: Mapped[SessionRow] = relationship(back_populates="commands")


class PlanRow(Base):
    __tablename__ = "plans"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    session_id: Mapped[int] = mapped_column(ForeignKey("sessions.id", ondelete="CASCADE"), index=True)
    robot_plan_id: Mapped[int] = mapped_column(Integer)
    robot_command_id: Mapped[int] = mapped_column(Integer)
    revision: Mapped[int] = mapped_column(Integer)
    text: Mapped[str] = mapped_column(Text)
    plan: Mapped[dict[str, Any]] = mapped_column(JSON)
    created_at: Mapped[datetime] = mapped_column(DateTime(timezone=True))
    state: Mapped[str] = mapped_column(String(16))
    finished_at: Mapped[datetime | None] = mapped_column(DateTime(timezone=True))


class StepResultRow(Base):
    __tablename__ = "step_results"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    session_id: Mapped[int] = mapped_column(ForeignKey("sessions.id", ondelete="CASCADE"), index=True)
    robot_plan_id: Mapped[int] = mapped_column(Integer)
    step_index: Mapped[int] = mapped_column(Integer)
    action: Mapped[str] = mapped_column(String(32))
    args: Mapped[dict[str, Any]] = mapped_column(JSON)
    state: Mapped[str] = mapped_column(String(16))
    detail: Mapped[str] = mapped_column(Text)
    sim_start_s: Mapped[float | None] = mapped_column(Float)
    sim_end_s: Mapped[float | None] = mapped_column(Float)
    recorded_at: Mapped[datetime] = mapped_column(DateTime(timezone=True))


class EventRow(Base):
    __tablename__ = "events"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    session_id: Mapped[int] = mapped_column(ForeignKey("sessions.id", ondelete="CASCADE"), index=True)
    seq: Mapped[int] = mapped_column(Integer)
    kind: Mapped[str] = mapped_column(String(64), index=True)
    level: Mapped[int] = mapped_column(Integer)
    message: Mapped[str] = mapped_column(Text)
    data: Mapped[dict[str, Any] | None] = mapped_column(JSON)
    wall_time: Mapped[datetime] = mapped_column(DateTime(timezone=True))
    sim_time_s: Mapped[float] = mapped_column(Float)


class BehaviourRunRow(Base):
    """A behaviour run: what was started with which parameters, how it ended and why, and its feedback lines (its
    state changes and snapshots are events)."""

    __tablename__ = "behaviour_runs"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    session_id: Mapped[int] = mapped_column(ForeignKey("sessions.id", ondelete="CASCADE"), index=True)
    robot_run_id: Mapped[int] = mapped_column(Integer)
    robot_command_id: Mapped[int | None] = mapped_column(Integer)
    name: Mapped[str] = mapped_column(String(64))
    params: Mapped[dict[str, Any]] = mapped_column(JSON)
    source: Mapped[str] = mapped_column(String(16))
    started_at: Mapped[datetime] = mapped_column(DateTime(timezone=True))
    sim_start_s: Mapped[float] = mapped_column(Float)
    state: Mapped[str] = mapped_column(String(16))  # running | succeeded | failed | stopped
    finished_at: Mapped[datetime | None] = mapped_column(DateTime(timezone=True))
    sim_end_s: Mapped[float | None] = mapped_column(Float)
    reason: Mapped[str | None] = mapped_column(Text)
    feedback: Mapped[list[str] | None] = mapped_column(JSON)


class TranscriptRow(Base):
    """What was heard: the transcript, how sure the recogniser was, its other wordings, and the recording (a WAV
    under the audio directory, by a path relative to it)."""

    __tablename__ = "transcripts"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    session_id: Mapped[int] = mapped_column(ForeignKey("sessions.id", ondelete="CASCADE"), index=True)
    received_at: Mapped[datetime] = mapped_column(DateTime(timezone=True))
    source: Mapped[str] = mapped_column(String(16))  # browser | cli | robot_mic
    text: Mapped[str] = mapped_column(Text)
    confidence: Mapped[float] = mapped_column(Float)
    engine: Mapped[str] = mapped_column(String(32))
    in_grammar: Mapped[bool] = mapped_column(Boolean)
    audio_s: Mapped[float] = mapped_column(Float)
    decode_ms: Mapped[float] = mapped_column(Float)
    audio_path: Mapped[str | None] = mapped_column(String(512))
    # the recogniser's other wordings, nearly as likely (whisper's beam): what the robot asked "did you mean ...?" of
    alternatives: Mapped[list[str] | None] = mapped_column(JSON)


class TelemetryChunkRow(Base):
    """Consecutive telemetry samples (about half a second), compressed (app.sessions.telemetry_codec): the robot's
    and the objects' motion and the signals plotted in review, at 30+ Hz."""

    __tablename__ = "telemetry_chunks"
    __table_args__ = (Index("ix_telemetry_chunks_session_time", "session_id", "sim_t0"),)

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    session_id: Mapped[int] = mapped_column(ForeignKey("sessions.id", ondelete="CASCADE"))
    first_seq: Mapped[int] = mapped_column(Integer)
    count: Mapped[int] = mapped_column(Integer)
    sim_t0: Mapped[float] = mapped_column(Float)
    sim_t1: Mapped[float] = mapped_column(Float)
    wall_t0: Mapped[datetime] = mapped_column(DateTime(timezone=True))
    wall_t1: Mapped[datetime] = mapped_column(DateTime(timezone=True))
    data: Mapped[bytes] = mapped_column(LargeBinary)


class CameraFrameRow(Base):
    """A head camera frame as the operator saw it (JPEG), with what was detected in it."""

    __tablename__ = "camera_frames"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    session_id: Mapped[int] = mapped_column(ForeignKey("sessions.id", ondelete="CASCADE"), index=True)
    seq: Mapped[int] = mapped_column(Integer)
    sim_time_s: Mapped[float] = mapped_column(Float)
    wall_time: Mapped[datetime] = mapped_column(DateTime(timezone=True))
    width: Mapped[int] = mapped_column(Integer)
    height: Mapped[int] = mapped_column(Integer)
    jpeg: Mapped[bytes] = mapped_column(LargeBinary)
    detections: Mapped[list[dict[str, Any]] | None] = mapped_column(JSON)


class LidarScanRow(Base):
    """A lidar scan (as robot.interface.ScanView), a few a second: the ring of ranges and the estimated pose it was
    taken from, for review and export (Foxglove's LaserScan)."""

    __tablename__ = "lidar_scans"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    session_id: Mapped[int] = mapped_column(ForeignKey("sessions.id", ondelete="CASCADE"), index=True)
    sim_time_s: Mapped[float] = mapped_column(Float)
    wall_time: Mapped[datetime] = mapped_column(DateTime(timezone=True))
    x: Mapped[float] = mapped_column(Float)  # the sensor's estimated pose (world frame)
    y: Mapped[float] = mapped_column(Float)
    yaw: Mapped[float] = mapped_column(Float)
    height_m: Mapped[float] = mapped_column(Float)
    angle_min: Mapped[float] = mapped_column(Float)
    angle_increment: Mapped[float] = mapped_column(Float)
    range_max: Mapped[float] = mapped_column(Float)
    ranges: Mapped[bytes] = mapped_column(LargeBinary)  # float32, little-endian; inf where nothing was hit


class OccupancyMapRow(Base):
    """The occupancy map (as robot.interface.OccupancyMap) when it changed, at most every few seconds."""

    __tablename__ = "occupancy_maps"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    session_id: Mapped[int] = mapped_column(ForeignKey("sessions.id", ondelete="CASCADE"), index=True)
    sim_time_s: Mapped[float] = mapped_column(Float)
    wall_time: Mapped[datetime] = mapped_column(DateTime(timezone=True))
    resolution: Mapped[float] = mapped_column(Float)
    origin_x: Mapped[float] = mapped_column(Float)  # the corner of cell (0, 0)
    origin_y: Mapped[float] = mapped_column(Float)
    width: Mapped[int] = mapped_column(Integer)
    height: Mapped[int] = mapped_column(Integer)
    scans: Mapped[int] = mapped_column(Integer)  # scans integrated so far
    data: Mapped[bytes] = mapped_column(LargeBinary)  # zlib of int8 cells, x fastest: 0-100, or -1 unknown


# The users' tables share this metadata (one database, one migration history): registered with it here.
from app.auth import models as _auth_models  # noqa: E402, F401
