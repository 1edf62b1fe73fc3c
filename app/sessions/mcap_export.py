"""A session as an MCAP file with Foxglove's standard schemas, to open in Foxglove or Lichtblick:

- `/tf` (foxglove.FrameTransforms): every body of the robot and of the world, as a kinematic tree from `world`;
- `/scene` (foxglove.SceneUpdate): the bodies' shapes (the robot's collision shapes, the furniture, the objects),
  each attached to its body's frame, so the 3D panel shows the robot moving with no URDF needed;
- `/joint_states` and `/joint_targets` (foxglove.JointStates): measured positions, velocities and torques, and
  what the controller commanded;
- `/telemetry` (JSON): centre of mass, control tick time, battery voltage, current and charge, for plots;
- `/camera/image/compressed` (foxglove.CompressedImage) and `/camera/annotations` (foxglove.ImageAnnotations: the
  detections' boxes and labels), when frames were recorded;
- `/log` (foxglove.Log): events, commands, what was heard, plans and step results, with their levels;
- `/plans` (JSON): every plan revision as the robot ran it.

Message times are the session's start plus simulated time, so a replay in Foxglove runs at the robot's own speed
(a headless `humanoid run` is recorded faster than real time). Messages are written in time order.
"""

from __future__ import annotations

import heapq
from collections.abc import Iterator
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import foxglove
import mujoco
import numpy as np
from foxglove.channels import (
    CompressedImageChannel,
    FrameTransformsChannel,
    ImageAnnotationsChannel,
    JointStatesChannel,
    LogChannel,
    SceneUpdateChannel,
)
from foxglove.mcap import MCAPCompression, MCAPWriteOptions
from foxglove.messages import (
    Color,
    CompressedImage,
    CubePrimitive,
    CylinderPrimitive,
    FrameTransform,
    FrameTransforms,
    ImageAnnotations,
    JointState,
    JointStates,
    Log,
    LogLevel,
    Point2,
    Point3,
    PointsAnnotation,
    PointsAnnotationType,
    Pose,
    Quaternion,
    SceneEntity,
    SceneUpdate,
    SpherePrimitive,
    TextAnnotation,
    Timestamp,
    TriangleListPrimitive,
    Vector3,
)
from sqlalchemy import select
from sqlalchemy.orm import sessionmaker

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
from app.sessions.queries import SimClock, telemetry_bounds
from app.sessions.scene import session_scene
from app.sessions.telemetry_codec import decode_rows
from robot.telemetry import TelemetryLayout

DETAILED_MESH_GROUP = 2  # the robot's display meshes (~930k triangles): the collision shapes stand in for them
CAMERA_FRAME = "head_camera"
TELEMETRY_SCHEMA = {
    "title": "humanoid.Telemetry",
    "type": "object",
    "properties": {
        "timestamp": {"type": "object", "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}}},
        "sim_time_s": {"type": "number"},
        "com": {"type": "object", "properties": {k: {"type": "number"} for k in "xyz"}},
        "tick_ms": {"type": "number"},
        "battery": {"type": "object", "properties": {k: {"type": "number"} for k in ("voltage_v", "current_a", "soc")}},
    },
}
PLAN_SCHEMA = {
    "title": "humanoid.Plan",
    "type": "object",
    "properties": {
        "plan_id": {"type": "integer"},
        "revision": {"type": "integer"},
        "text": {"type": "string"},
        "state": {"type": "string"},
        "steps": {"type": "array", "items": {"type": "object"}},
    },
}
_LEVELS = {0: LogLevel.Info, 1: LogLevel.Warning, 2: LogLevel.Error, 3: LogLevel.Warning}


@dataclass(order=True)
class _Timed:
    """A message for a channel at a time; ordered by time (then by insertion, for a stable order)."""

    t_ns: int
    order: int
    channel: Any = field(compare=False)
    message: Any = field(compare=False)


def _stamp(t_ns: int) -> Timestamp:
    sec, nsec = divmod(int(t_ns), 1_000_000_000)
    return Timestamp(sec, nsec)


def _quat(wxyz: np.ndarray) -> Quaternion:
    return Quaternion(x=float(wxyz[1]), y=float(wxyz[2]), z=float(wxyz[3]), w=float(wxyz[0]))


def _pose(pos: np.ndarray, wxyz: np.ndarray) -> Pose:
    return Pose(position=Vector3(x=float(pos[0]), y=float(pos[1]), z=float(pos[2])), orientation=_quat(wxyz))


def _finite(value: float) -> float | None:
    return float(value) if np.isfinite(value) else None


class _Timeline:
    """Session time -> MCAP time: the session's start plus simulated time since the first sample."""

    def __init__(self, start: datetime, sim_zero: float) -> None:
        self._start_ns = int((start if start.tzinfo else start.replace(tzinfo=UTC)).timestamp() * 1e9)
        self._sim_zero = sim_zero

    def ns(self, sim_time_s: float | None) -> int:
        sim = self._sim_zero if sim_time_s is None else sim_time_s
        return self._start_ns + round(max(sim - self._sim_zero, 0.0) * 1e9)


def export_session_mcap(factory: sessionmaker, session_id: int, path: str | Path) -> dict[str, int]:
    """Write the session to `path`; returns the number of messages per topic. KeyError when there is no such
    session."""
    with factory() as db:
        row = db.get(SessionRow, session_id)
        if row is None:
            raise KeyError(f"no session {session_id}")
        layout = TelemetryLayout.from_json(row.telemetry_layout) if row.telemetry_layout else None
        first_sim = db.scalar(select(TelemetryChunkRow.sim_t0).where(TelemetryChunkRow.session_id == session_id)
                              .order_by(TelemetryChunkRow.sim_t0).limit(1))  # fmt: skip
        events = db.scalars(select(EventRow).where(EventRow.session_id == session_id).order_by(EventRow.seq)).all()
        clock = SimClock.of(list(events), telemetry_bounds(db, session_id))
        sim_zero = first_sim if first_sim is not None else (events[0].sim_time_s if events else 0.0)
        timeline = _Timeline(row.started_at, sim_zero)
        model, _ = session_scene(row.scene_mjcf, row.seed)
        counts: dict[str, int] = {}
        ctx = foxglove.Context()  # a private context: concurrent exports never mix
        options = MCAPWriteOptions(compression=MCAPCompression.Zstd, compression_threads=0)
        with foxglove.open_mcap(str(path), allow_overwrite=True, context=ctx, writer_options=options) as writer:
            channels = _Channels(ctx)
            writer.write_metadata("session", {
                "id": str(row.id), "kind": row.kind, "seed": str(row.seed), "robot_model": row.robot_model or "",
                "started_at": row.started_at.isoformat(), "outcome": row.outcome or "",
                "time_base": "session start + simulated time",
            })  # fmt: skip
            writer.attach(log_time=timeline.ns(sim_zero), create_time=timeline.ns(sim_zero), name="scene.xml",
                          media_type="application/xml", data=(row.scene_mjcf or "").encode())  # fmt: skip
            side = list(_side_messages(db, session_id, channels, timeline, clock, list(events), model))
            heapq.heapify(side)
            order = len(side)
            bodies = _Bodies(model)
            for rows in _telemetry_chunks(db, session_id):
                for r in rows:
                    t_ns = timeline.ns(r[0])
                    while side and side[0].t_ns <= t_ns:
                        _log(heapq.heappop(side), counts)
                    for item in _telemetry_messages(r, t_ns, layout, bodies, channels):
                        order += 1
                        _log(_Timed(t_ns, order, *item), counts)
            while side:
                _log(heapq.heappop(side), counts)
    return counts


def _log(item: _Timed, counts: dict[str, int]) -> None:
    item.channel.log(item.message, log_time=item.t_ns)
    topic = item.channel.topic()
    counts[topic] = counts.get(topic, 0) + 1


class _Channels:
    def __init__(self, ctx: foxglove.Context) -> None:
        self.tf = FrameTransformsChannel("/tf", context=ctx)
        self.scene = SceneUpdateChannel("/scene", context=ctx)
        self.joints = JointStatesChannel("/joint_states", context=ctx)
        self.targets = JointStatesChannel("/joint_targets", context=ctx)
        self.telemetry = foxglove.Channel("/telemetry", schema=TELEMETRY_SCHEMA, context=ctx)
        self.camera = CompressedImageChannel("/camera/image/compressed", context=ctx)
        self.annotations = ImageAnnotationsChannel("/camera/annotations", context=ctx)
        self.log = LogChannel("/log", context=ctx)
        self.plans = foxglove.Channel("/plans", schema=PLAN_SCHEMA, context=ctx)


def _telemetry_chunks(db: Any, session_id: int) -> Iterator[np.ndarray]:
    for (blob,) in db.execute(select(TelemetryChunkRow.data).where(TelemetryChunkRow.session_id == session_id)
                              .order_by(TelemetryChunkRow.sim_t0, TelemetryChunkRow.first_seq)):  # fmt: skip
        yield decode_rows(blob)


# ---------------------------------------------------------------------------------------------------------------
# the scene and its motion


class _Bodies:
    """Body poses from a telemetry row (qpos, mocap), as transforms from each body's parent."""

    def __init__(self, model: mujoco.MjModel) -> None:
        self.model = model
        self.data = mujoco.MjData(model)
        self.names = ["world"] + [model.body(i).name or f"body_{i}" for i in range(1, model.nbody)]
        self.parents = np.asarray(model.body_parentid[1:], dtype=int)

    def relative_poses(self, qpos: np.ndarray, mocap: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """Each body's (1..nbody-1) translation and rotation (wxyz) in its parent's frame."""
        m, d = self.model, self.data
        n = min(qpos.size, m.nq)
        d.qpos[:n] = np.nan_to_num(qpos[:n])
        if mocap is not None and mocap.size == d.mocap_pos.size and np.all(np.isfinite(mocap)):
            d.mocap_pos[:] = mocap.reshape(d.mocap_pos.shape)
        mujoco.mj_kinematics(m, d)
        parents = self.parents
        rot_p = d.xmat[parents].reshape(-1, 3, 3)
        translation = np.einsum("bji,bj->bi", rot_p, d.xpos[1:] - d.xpos[parents])
        return translation, _quat_multiply(_quat_conjugate(d.xquat[parents]), d.xquat[1:])

    def transforms(self, qpos: np.ndarray, mocap: np.ndarray | None, stamp: Timestamp) -> FrameTransforms:
        translation, rotation = self.relative_poses(qpos, mocap)
        names = self.names
        out = [
            FrameTransform(timestamp=stamp, parent_frame_id=names[p], child_frame_id=names[b + 1],
                           translation=Vector3(x=float(t[0]), y=float(t[1]), z=float(t[2])), rotation=_quat(q))
            for b, (p, t, q) in enumerate(zip(self.parents, translation, rotation, strict=True))
        ]  # fmt: skip
        return FrameTransforms(transforms=out)

    def scene(self, stamp: Timestamp) -> SceneUpdate:
        """Every drawable geom as a primitive in its body's frame (frame-locked: it moves with the body)."""
        m = self.model
        by_body: dict[int, dict[str, list]] = {}
        for g in range(m.ngeom):
            if m.geom_group[g] == DETAILED_MESH_GROUP or m.geom_rgba[g][3] == 0:
                continue
            prims = by_body.setdefault(int(m.geom_bodyid[g]), {"cubes": [], "spheres": [], "cylinders": [],
                                                               "triangles": []})  # fmt: skip
            self._add_geom(g, prims)
        entities = [
            SceneEntity(timestamp=stamp, frame_id=self.names[b], id=self.names[b], frame_locked=True, **prims)
            for b, prims in by_body.items()
        ]
        return SceneUpdate(entities=entities)

    def _add_geom(self, g: int, prims: dict[str, list]) -> None:
        m = self.model
        rgba = m.mat_rgba[m.geom_matid[g]] if m.geom_matid[g] >= 0 else m.geom_rgba[g]
        color = Color(r=float(rgba[0]), g=float(rgba[1]), b=float(rgba[2]), a=float(rgba[3]))
        pose = _pose(m.geom_pos[g], m.geom_quat[g])
        size = m.geom_size[g]
        kind = m.geom_type[g]
        if kind == mujoco.mjtGeom.mjGEOM_BOX:
            prims["cubes"].append(CubePrimitive(pose=pose, size=_vec(2 * size), color=color))
        elif kind == mujoco.mjtGeom.mjGEOM_PLANE:
            extent = [2 * s if s > 0 else 20.0 for s in size[:2]]
            prims["cubes"].append(CubePrimitive(pose=pose, size=_vec([extent[0], extent[1], 0.002]), color=color))
        elif kind == mujoco.mjtGeom.mjGEOM_SPHERE:
            prims["spheres"].append(SpherePrimitive(pose=pose, size=_vec([2 * size[0]] * 3), color=color))
        elif kind == mujoco.mjtGeom.mjGEOM_ELLIPSOID:
            prims["spheres"].append(SpherePrimitive(pose=pose, size=_vec(2 * size), color=color))
        elif kind in (mujoco.mjtGeom.mjGEOM_CYLINDER, mujoco.mjtGeom.mjGEOM_CAPSULE):
            r, h = size[0], size[1]
            prims["cylinders"].append(CylinderPrimitive(pose=pose, size=_vec([2 * r, 2 * r, 2 * h]), bottom_scale=1.0,
                                                        top_scale=1.0, color=color))  # fmt: skip
            if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
                rot = np.zeros(9)
                mujoco.mju_quat2Mat(rot, m.geom_quat[g])
                axis = rot.reshape(3, 3)[:, 2]
                for sign in (-1.0, 1.0):
                    centre = m.geom_pos[g] + sign * h * axis
                    prims["spheres"].append(SpherePrimitive(pose=_pose(centre, m.geom_quat[g]),
                                                            size=_vec([2 * r] * 3), color=color))  # fmt: skip
        elif kind == mujoco.mjtGeom.mjGEOM_MESH:
            mesh = m.geom_dataid[g]
            verts = m.mesh_vert[m.mesh_vertadr[mesh] : m.mesh_vertadr[mesh] + m.mesh_vertnum[mesh]]
            faces = m.mesh_face[m.mesh_faceadr[mesh] : m.mesh_faceadr[mesh] + m.mesh_facenum[mesh]]
            points = [Point3(x=float(v[0]), y=float(v[1]), z=float(v[2])) for v in verts]
            prims["triangles"].append(TriangleListPrimitive(pose=pose, points=points, color=color,
                                                            indices=[int(i) for i in faces.ravel()]))  # fmt: skip


def _quat_conjugate(q: np.ndarray) -> np.ndarray:
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def _quat_multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise Hamilton products of (n, 4) wxyz quaternions."""
    w1, x1, y1, z1 = a.T
    w2, x2, y2, z2 = b.T
    return np.stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2], axis=1)  # fmt: skip


def _vec(values: Any) -> Vector3:
    return Vector3(x=float(values[0]), y=float(values[1]), z=float(values[2]))


def _telemetry_messages(r: np.ndarray, t_ns: int, layout: TelemetryLayout | None, bodies: _Bodies,
                        channels: _Channels) -> Iterator[tuple[Any, Any]]:  # fmt: skip
    stamp = _stamp(t_ns)
    if layout is None:
        return
    s = layout.slices()
    mocap = r[s["mocap_pos"]] if "mocap_pos" in s else None
    yield channels.tf, bodies.transforms(r[s["qpos"]], mocap, stamp)
    if "joint_position" not in s:
        return
    names = layout.joint_names
    pos, vel, torque, target = (r[s[k]] for k in ("joint_position", "joint_velocity", "joint_torque", "joint_target"))
    yield channels.joints, JointStates(timestamp=stamp, joints=[
        JointState(name=n, position=_finite(pos[i]), velocity=_finite(vel[i]), effort=_finite(torque[i]))
        for i, n in enumerate(names)
    ])  # fmt: skip
    yield channels.targets, JointStates(timestamp=stamp, joints=[
        JointState(name=n, position=_finite(target[i])) for i, n in enumerate(names)
    ])  # fmt: skip
    com = r[s["com"]]
    yield channels.telemetry, {
        "timestamp": {"sec": stamp.sec, "nsec": stamp.nsec},
        "sim_time_s": float(r[0]),
        "com": {"x": _finite(com[0]), "y": _finite(com[1]), "z": _finite(com[2])},
        "tick_ms": _finite(r[s["tick_ms"]][0]),
        "battery": {"voltage_v": _finite(r[s["battery_v"]][0]), "current_a": _finite(r[s["battery_a"]][0]),
                    "soc": _finite(r[s["battery_soc"]][0])},
    }  # fmt: skip


# ---------------------------------------------------------------------------------------------------------------
# everything else, which is small beside the telemetry


def _side_messages(db: Any, sid: int, channels: _Channels, timeline: _Timeline, clock: SimClock,
                   events: list[EventRow], model: mujoco.MjModel) -> Iterator[_Timed]:  # fmt: skip
    counter = iter(range(1_000_000_000))
    start = timeline.ns(None)
    yield _Timed(start, next(counter), channels.scene, _Bodies(model).scene(_stamp(start)))

    def log(t_ns: int, level: int, name: str, message: str) -> _Timed:
        return _Timed(
            t_ns,
            next(counter),
            channels.log,
            Log(timestamp=_stamp(t_ns), level=_LEVELS.get(level, LogLevel.Info), message=message, name=name),
        )

    for e in events:
        yield log(timeline.ns(e.sim_time_s), e.level, e.kind, e.message)
    for c in db.scalars(select(CommandRow).where(CommandRow.session_id == sid).order_by(CommandRow.id)):
        verdict = "accepted" if c.accepted else f"refused ({c.refusal}): {'; '.join(c.errors or [])}"
        yield log(timeline.ns(clock.sim_at(c.received_at)), 0 if c.accepted else 1, f"command/{c.source}",
                  f'"{c.text}" {verdict}')  # fmt: skip
    for t in db.scalars(select(TranscriptRow).where(TranscriptRow.session_id == sid).order_by(TranscriptRow.id)):
        yield log(timeline.ns(clock.sim_at(t.received_at)), 0, f"speech/{t.source}",
                  f'heard "{t.text}" (confidence {t.confidence:.2f}, {t.engine})')  # fmt: skip
    steps: dict[int, list[dict[str, Any]]] = {}
    for st in db.scalars(select(StepResultRow).where(StepResultRow.session_id == sid).order_by(StepResultRow.id)):
        steps.setdefault(st.robot_plan_id, []).append(
            {"index": st.step_index, "action": st.action, "args": st.args, "state": st.state, "detail": st.detail,
             "sim_start_s": st.sim_start_s, "sim_end_s": st.sim_end_s}
        )  # fmt: skip
    for p in db.scalars(select(PlanRow).where(PlanRow.session_id == sid).order_by(PlanRow.id)):
        yield _Timed(timeline.ns(clock.sim_at(p.created_at)), next(counter), channels.plans,
                     {"plan_id": p.robot_plan_id, "revision": p.revision, "text": p.text, "state": p.state,
                      "steps": steps.get(p.robot_plan_id, p.plan.get("steps", []) if isinstance(p.plan, dict)
                                         else [])})  # fmt: skip
    for f in db.scalars(select(CameraFrameRow).where(CameraFrameRow.session_id == sid).order_by(CameraFrameRow.id)):
        t_ns = timeline.ns(f.sim_time_s)
        stamp = _stamp(t_ns)
        yield _Timed(
            t_ns,
            next(counter),
            channels.camera,
            CompressedImage(timestamp=stamp, frame_id=CAMERA_FRAME, data=f.jpeg, format="jpeg"),
        )
        yield _Timed(t_ns, next(counter), channels.annotations, _annotations(f.detections or [], stamp))


def _annotations(detections: list[dict[str, Any]], stamp: Timestamp) -> ImageAnnotations:
    green = Color(r=0.1, g=0.9, b=0.2, a=1.0)
    boxes, labels = [], []
    for d in detections:
        x0, y0, x1, y1 = (float(v) for v in d["box"])
        boxes.append(PointsAnnotation(timestamp=stamp, type=PointsAnnotationType.LineLoop, outline_color=green,
                                      thickness=2.0, points=[Point2(x=x0, y=y0), Point2(x=x1, y=y0),
                                                             Point2(x=x1, y=y1), Point2(x=x0, y=y1)]))  # fmt: skip
        labels.append(TextAnnotation(timestamp=stamp, position=Point2(x=x0, y=max(y0 - 4.0, 0.0)), text=d["label"],
                                     font_size=14.0, text_color=green))  # fmt: skip
    return ImageAnnotations(timestamp=stamp, points=boxes, texts=labels)
