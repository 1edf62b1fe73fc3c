"""A session as an MCAP file with Foxglove's standard schemas, to open in Foxglove or Lichtblick (with
docs/foxglove-layout.json, the robot, the camera and the log in one view):

- `/robot_description` (std_msgs/String, JSON): the robot's URDF (robot.model.urdf, from the session's own model),
  which the 3D panels draw the robot from;
- `/tf` (foxglove.FrameTransforms): every body of the robot and of the world, as a kinematic tree from `world`;
  the robot's bodies are its URDF's links, so the drawn robot moves;
- `/scene` (foxglove.SceneUpdate): the world's shapes (furniture, walls, objects), each on its body's frame;
- `/joint_states` and `/joint_targets` (foxglove.JointStates): measured positions, velocities and torques, and
  what the controller commanded;
- `/telemetry` (JSON): centre of mass, control tick time, battery voltage, current and charge, for plots;
- `/camera/image/compressed` (foxglove.CompressedImage) and `/camera/annotations` (foxglove.ImageAnnotations: the
  detections' boxes and labels), when frames were recorded;
- `/scan` (foxglove.LaserScan) and `/map` (foxglove.Grid): the lidar ring and the occupancy map, when recorded;
- `/log` (foxglove.Log): events, commands, what was heard, plans and step results, with their levels;
- `/plans` (JSON): every plan revision as the robot ran it.

Message times are the session's start plus simulated time, so a replay in Foxglove runs at the robot's own speed
(a headless `humanoid run` is recorded faster than real time). Messages are written in time order.
"""

from __future__ import annotations

import heapq
import logging
import zlib
from collections.abc import Iterator
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import foxglove
import mujoco
import numpy as np
from foxglove.mcap import MCAPCompression, MCAPWriteOptions
from foxglove.messages import (
    Color,
    ImageAnnotations,
    Point2,
    PointsAnnotation,
    PointsAnnotationType,
    TextAnnotation,
    Timestamp,
)
from sqlalchemy import select
from sqlalchemy.orm import sessionmaker

from app.foxglove import messages as fm
from app.foxglove.channels import FoxgloveChannels
from app.foxglove.frames import SceneFrames
from app.sessions.models import (
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
from app.sessions.queries import SimClock, telemetry_bounds
from app.sessions.scene import session_scene
from app.sessions.telemetry_codec import decode_rows
from robot.interface import OccupancyMap, ScanView
from robot.model import humanoid_v1
from robot.model.urdf import urdf_from_model
from robot.telemetry import TelemetryLayout

log = logging.getLogger(__name__)


@dataclass(order=True)
class _Timed:
    """A message for a channel at a time; ordered by time (then by insertion, for a stable order)."""

    t_ns: int
    order: int
    channel: Any = field(compare=False)
    message: Any = field(compare=False)


class _Timeline:
    """Session time -> MCAP time: the session's start plus simulated time since the first sample."""

    def __init__(self, start: datetime, sim_zero: float) -> None:
        self._start_ns = int((start if start.tzinfo else start.replace(tzinfo=UTC)).timestamp() * 1e9)
        self._sim_zero = sim_zero

    def ns(self, sim_time_s: float | None) -> int:
        sim = self._sim_zero if sim_time_s is None else sim_time_s
        return self._start_ns + round(max(sim - self._sim_zero, 0.0) * 1e9)


def session_urdf(model: mujoco.MjModel, robot_model: str | None) -> str | None:
    """The URDF of the robot in a session's model; None (with a warning) when URDF cannot describe it."""
    try:
        return urdf_from_model(model, humanoid_v1.TRUNK_BODY, robot_model or humanoid_v1.MODEL_NAME)
    except (KeyError, ValueError) as exc:
        log.warning("no robot description for this session's model: %s", exc)
        return None


def export_session_mcap(factory: sessionmaker, session_id: int, path: str | Path) -> dict[str, int]:
    """Write the session to `path`; returns the number of messages per topic. KeyError when there is no such
    session."""
    with factory() as db:
        row = db.get(SessionRow, session_id)
        if row is None:
            raise KeyError(f"no session {session_id}")
        layout = TelemetryLayout.from_json(row.telemetry_layout) if row.telemetry_layout else None
        first_sim = db.scalar(
            select(TelemetryChunkRow.sim_t0)
            .where(TelemetryChunkRow.session_id == session_id)
            .order_by(TelemetryChunkRow.sim_t0)
            .limit(1)
        )
        events = db.scalars(select(EventRow).where(EventRow.session_id == session_id).order_by(EventRow.seq)).all()
        clock = SimClock.of(list(events), telemetry_bounds(db, session_id))
        sim_zero = first_sim if first_sim is not None else (events[0].sim_time_s if events else 0.0)
        timeline = _Timeline(row.started_at, sim_zero)
        model, _ = session_scene(row.scene_mjcf, row.seed)
        counts: dict[str, int] = {}
        ctx = foxglove.Context()  # a private context: concurrent exports never mix
        options = MCAPWriteOptions(compression=MCAPCompression.Zstd, compression_threads=0)
        with foxglove.open_mcap(str(path), allow_overwrite=True, context=ctx, writer_options=options) as writer:
            channels = FoxgloveChannels(ctx)
            writer.write_metadata(
                "session",
                {
                    "id": str(row.id),
                    "kind": row.kind,
                    "seed": str(row.seed),
                    "robot_model": row.robot_model or "",
                    "started_at": row.started_at.isoformat(),
                    "outcome": row.outcome or "",
                    "time_base": "session start + simulated time",
                },
            )
            writer.attach(
                log_time=timeline.ns(sim_zero),
                create_time=timeline.ns(sim_zero),
                name="scene.xml",
                media_type="application/xml",
                data=(row.scene_mjcf or "").encode(),
            )
            frames = SceneFrames(model)
            side = list(_side_messages(db, session_id, channels, timeline, clock, list(events), frames, row))
            heapq.heapify(side)
            order = len(side)
            for rows in _telemetry_chunks(db, session_id):
                for r in rows:
                    t_ns = timeline.ns(r[0])
                    while side and side[0].t_ns <= t_ns:
                        _log(heapq.heappop(side), counts)
                    for item in _telemetry_messages(r, t_ns, layout, frames, channels):
                        order += 1
                        _log(_Timed(t_ns, order, *item), counts)
            while side:
                _log(heapq.heappop(side), counts)
    return counts


def _log(item: _Timed, counts: dict[str, int]) -> None:
    item.channel.log(item.message, log_time=item.t_ns)
    topic = item.channel.topic()
    counts[topic] = counts.get(topic, 0) + 1


def _telemetry_chunks(db: Any, session_id: int) -> Iterator[np.ndarray]:
    query = (
        select(TelemetryChunkRow.data)
        .where(TelemetryChunkRow.session_id == session_id)
        .order_by(TelemetryChunkRow.sim_t0, TelemetryChunkRow.first_seq)
    )
    for (blob,) in db.execute(query):
        yield decode_rows(blob)


def _telemetry_messages(
    r: np.ndarray, t_ns: int, layout: TelemetryLayout | None, frames: SceneFrames, channels: FoxgloveChannels
) -> Iterator[tuple[Any, Any]]:
    if layout is None:
        return
    s = layout.slices()
    mocap = r[s["mocap_pos"]] if "mocap_pos" in s else None
    yield channels.tf, frames.transforms(r[s["qpos"]], mocap, t_ns)
    if "joint_position" not in s:
        return
    names = layout.joint_names
    pos, vel, torque, target = (r[s[k]] for k in ("joint_position", "joint_velocity", "joint_torque", "joint_target"))
    yield channels.joints, fm.joint_states(names, pos, t_ns, velocities=vel, efforts=torque)
    yield channels.targets, fm.joint_states(names, target, t_ns)
    com = r[s["com"]]
    when = fm.stamp(t_ns)
    yield (
        channels.telemetry,
        {
            "timestamp": {"sec": when.sec, "nsec": when.nsec},
            "sim_time_s": float(r[0]),
            "com": {"x": fm.finite(com[0]), "y": fm.finite(com[1]), "z": fm.finite(com[2])},
            "tick_ms": fm.finite(r[s["tick_ms"]][0]),
            "battery": {
                "voltage_v": fm.finite(r[s["battery_v"]][0]),
                "current_a": fm.finite(r[s["battery_a"]][0]),
                "soc": fm.finite(r[s["battery_soc"]][0]),
            },
        },
    )


# ---------------------------------------------------------------------------------------------------------------
# everything else, which is small beside the telemetry


def scan_view(row: LidarScanRow) -> ScanView:
    """A stored scan as the robot published it."""
    ranges = tuple(float(v) for v in np.frombuffer(row.ranges, dtype="<f4"))
    return ScanView(
        row.sim_time_s, (row.x, row.y, row.yaw), row.height_m, row.angle_min, row.angle_increment, row.range_max, ranges
    )


def occupancy_map(row: OccupancyMapRow) -> OccupancyMap:
    """A stored map as the robot published it."""
    return OccupancyMap(
        row.sim_time_s,
        row.resolution,
        (row.origin_x, row.origin_y),
        row.width,
        row.height,
        zlib.decompress(row.data),
        row.scans,
    )


def _side_messages(
    db: Any,
    sid: int,
    channels: FoxgloveChannels,
    timeline: _Timeline,
    clock: SimClock,
    events: list[EventRow],
    frames: SceneFrames,
    session: SessionRow,
) -> Iterator[_Timed]:
    counter = iter(range(1_000_000_000))
    start = timeline.ns(None)
    urdf = session_urdf(frames.model, session.robot_model)
    if urdf is not None:
        yield _Timed(start, next(counter), channels.description, fm.robot_description(urdf))
    yield _Timed(start, next(counter), channels.scene, frames.world_scene(start))

    def log_line(t_ns: int, level: int, name: str, message: str) -> _Timed:
        return _Timed(t_ns, next(counter), channels.log, fm.log(t_ns, level, name, message))

    for e in events:
        yield log_line(timeline.ns(e.sim_time_s), e.level, e.kind, e.message)
    for c in db.scalars(select(CommandRow).where(CommandRow.session_id == sid).order_by(CommandRow.id)):
        verdict = "accepted" if c.accepted else f"refused ({c.refusal}): {'; '.join(c.errors or [])}"
        t_ns = timeline.ns(clock.sim_at(c.received_at))
        yield log_line(t_ns, 0 if c.accepted else 1, f"command/{c.source}", f'"{c.text}" {verdict}')
    for t in db.scalars(select(TranscriptRow).where(TranscriptRow.session_id == sid).order_by(TranscriptRow.id)):
        also = "".join(f', or "{a}"' for a in t.alternatives or [])
        heard = f'heard "{t.text}"{also} (confidence {t.confidence:.2f}, {t.engine})'
        yield log_line(timeline.ns(clock.sim_at(t.received_at)), 0, f"speech/{t.source}", heard)
    yield from _plans(db, sid, channels, timeline, clock, counter)
    for f in db.scalars(select(CameraFrameRow).where(CameraFrameRow.session_id == sid).order_by(CameraFrameRow.id)):
        t_ns = timeline.ns(f.sim_time_s)
        yield _Timed(t_ns, next(counter), channels.camera, fm.compressed_image(f.jpeg, t_ns))
        yield _Timed(t_ns, next(counter), channels.annotations, _annotations(f.detections or [], fm.stamp(t_ns)))
    for scan in db.scalars(select(LidarScanRow).where(LidarScanRow.session_id == sid).order_by(LidarScanRow.id)):
        t_ns = timeline.ns(scan.sim_time_s)
        yield _Timed(t_ns, next(counter), channels.scan, fm.laser_scan(scan_view(scan), t_ns))
    maps = select(OccupancyMapRow).where(OccupancyMapRow.session_id == sid).order_by(OccupancyMapRow.id)
    for grid in db.scalars(maps):
        t_ns = timeline.ns(grid.sim_time_s)
        yield _Timed(t_ns, next(counter), channels.map, fm.occupancy_grid(occupancy_map(grid), t_ns))


def _plans(
    db: Any, sid: int, channels: FoxgloveChannels, timeline: _Timeline, clock: SimClock, counter: Iterator[int]
) -> Iterator[_Timed]:
    """Every plan revision, whole on /plans and as a line of the log (what it will do, step by step)."""
    steps: dict[int, list[dict[str, Any]]] = {}
    for st in db.scalars(select(StepResultRow).where(StepResultRow.session_id == sid).order_by(StepResultRow.id)):
        steps.setdefault(st.robot_plan_id, []).append(
            {
                "index": st.step_index,
                "action": st.action,
                "args": st.args,
                "state": st.state,
                "detail": st.detail,
                "sim_start_s": st.sim_start_s,
                "sim_end_s": st.sim_end_s,
            }
        )
    for p in db.scalars(select(PlanRow).where(PlanRow.session_id == sid).order_by(PlanRow.id)):
        t_ns = timeline.ns(clock.sim_at(p.created_at))
        planned = p.plan.get("steps", []) if isinstance(p.plan, dict) else []
        run = steps.get(p.robot_plan_id, planned)
        yield _Timed(
            t_ns,
            next(counter),
            channels.plans,
            {"plan_id": p.robot_plan_id, "revision": p.revision, "text": p.text, "state": p.state, "steps": run},
        )
        listed = "; ".join(
            f"{i + 1}. {st.get('action', '?')}({', '.join(str(v) for v in (st.get('args') or {}).values())})"
            for i, st in enumerate(planned)
        )
        message = f'plan {p.robot_plan_id} r{p.revision} for "{p.text}": {listed or "no steps"} ({p.state})'
        yield _Timed(t_ns, next(counter), channels.log, fm.log(t_ns, 0, "plan", message))


def _annotations(detections: list[dict[str, Any]], stamp: Timestamp) -> ImageAnnotations:
    green = Color(r=0.1, g=0.9, b=0.2, a=1.0)
    boxes, labels = [], []
    for d in detections:
        x0, y0, x1, y1 = (float(v) for v in d["box"])
        corners = [Point2(x=x0, y=y0), Point2(x=x1, y=y0), Point2(x=x1, y=y1), Point2(x=x0, y=y1)]
        boxes.append(
            PointsAnnotation(
                timestamp=stamp,
                type=PointsAnnotationType.LineLoop,
                outline_color=green,
                thickness=2.0,
                points=corners,
            )
        )
        labels.append(
            TextAnnotation(
                timestamp=stamp,
                position=Point2(x=x0, y=max(y0 - 4.0, 0.0)),
                text=d["label"],
                font_size=14.0,
                text_color=green,
            )
        )
    return ImageAnnotations(timestamp=stamp, points=boxes, texts=labels)
