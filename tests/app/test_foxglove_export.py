"""An exported session opens in Foxglove and Lichtblick with the robot drawn: the official `mcap` reader finds the
URDF on /robot_description (parseable, its links the /tf frames), the joint states, the camera, the lidar scan and
the map the recorder stored, and the plan in the log; the shipped layout shows topics the export has."""

from __future__ import annotations

import io
import json
import math
import time
from pathlib import Path

import numpy as np
import yourdfpy
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory
from sqlalchemy import func, select

from app.sessions.mcap_export import export_session_mcap
from app.sessions.models import CameraFrameRow, LidarScanRow, OccupancyMapRow
from app.sessions.queries import load_telemetry
from app.sessions.recorder import SessionRecorder
from app.settings import REPO_ROOT
from robot.interface import RunCommand

LAYOUT = REPO_ROOT / "docs" / "foxglove-layout.json"


def _count(factory, table) -> int:
    with factory() as db:
        return db.scalar(select(func.count()).select_from(table)) or 0


def _wait_until(condition, timeout_s: float) -> bool:
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.1)
    return True


def test_an_exported_session_carries_the_robot_its_sensors_and_its_log(store, make_worker, tmp_path: Path) -> None:
    factory, audio_dir = store
    worker = make_worker(realtime=True, perception=True)
    recorder = SessionRecorder(
        factory, worker, kind="run", seed=0, audio_dir=audio_dir, camera_hz=2.0, scan_hz=4.0, map_period_s=0.5
    )
    assert worker.wait_for(lambda s: s.plan is None, 5.0)
    worker.submit(RunCommand("say hello"))
    assert worker.wait_for(lambda s: s.plan is not None and s.plan.state == "succeeded", 60.0)
    stored = _wait_until(
        lambda: (
            _count(factory, LidarScanRow) >= 4
            and _count(factory, OccupancyMapRow) >= 2
            and _count(factory, CameraFrameRow) >= 2
        ),
        120.0,
    )
    recorder.close(outcome="succeeded")
    assert stored, "the recorder stored no scans, maps or frames"
    sid = recorder.session_id

    path = tmp_path / "session.mcap"
    counts = export_session_mcap(factory, sid, path)
    with factory() as db:
        layout, rows = load_telemetry(db, sid)
    with path.open("rb") as f:
        reader = make_reader(f, validate_crcs=True)
        summary = reader.get_summary()
        schemas = {c.topic: summary.schemas[c.schema_id].name for c in summary.channels.values()}
        per_channel = {summary.channels[i].topic: n for i, n in summary.statistics.channel_message_counts.items()}
        first: dict[str, object] = {}
        logs: list[str] = []
        protobuf = DecoderFactory()
        for schema, channel, message in reader.iter_messages():
            if channel.message_encoding == "json":
                decoded = json.loads(message.data)
            else:
                decoded = protobuf.decoder_for(channel.message_encoding, schema)(message.data)
            if channel.topic == "/log":
                logs.append(f"{decoded.name}: {decoded.message}")
            first.setdefault(channel.topic, decoded)
    assert schemas["/robot_description"] == "std_msgs/String" and schemas["/joint_states"] == "foxglove.JointStates"
    assert schemas["/tf"] == "foxglove.FrameTransforms" and schemas["/camera/image/compressed"] == (
        "foxglove.CompressedImage"
    )
    assert schemas["/scan"] == "foxglove.LaserScan" and schemas["/map"] == "foxglove.Grid"
    assert schemas["/log"] == "foxglove.Log"
    assert per_channel == counts
    assert per_channel["/robot_description"] == 1
    assert per_channel["/joint_states"] == per_channel["/tf"] == len(rows)
    assert per_channel["/scan"] == _count(factory, LidarScanRow) >= 4
    assert per_channel["/map"] == _count(factory, OccupancyMapRow) >= 2
    assert per_channel["/camera/image/compressed"] == _count(factory, CameraFrameRow) >= 2

    # the robot drawn: a URDF whose moving joints are the recorded joints, and whose every joint's parent and child
    # are a /tf transform (the 3D panel moves each link by it)
    urdf = yourdfpy.URDF.load(
        io.StringIO(first["/robot_description"]["data"]), load_meshes=False, load_collision_meshes=False
    )
    assert set(urdf.actuated_joint_names) == set(layout.joint_names)
    tf = {(t.parent_frame_id, t.child_frame_id) for t in first["/tf"].transforms}
    assert ("world", urdf.base_link) in tf
    assert {(j.parent, j.child) for j in urdf.robot.joints if j.type != "fixed"} <= tf
    assert first["/camera/image/compressed"].frame_id in urdf.link_map  # the camera's optical frame

    scan = first["/scan"]
    assert scan.frame_id == "world" and len(scan.ranges) == 512
    assert all(math.isnan(r) or 0 < r < 100 for r in scan.ranges)  # no return is NaN, never infinity
    grid = first["/map"]
    assert grid.cell_stride == 4 and len(grid.data) % grid.row_stride == 0 and grid.row_stride == 4 * grid.column_count
    alpha = np.frombuffer(grid.data, np.uint8)[3::4]
    assert (alpha == 0).any() and (alpha > 0).any()  # unknown cells transparent, known ones drawn
    assert any(line.startswith("plan:") and "say" in line for line in logs)

    # the shipped layout shows what the export carries
    config = json.loads(LAYOUT.read_text())["configById"]
    three_d = config["3D!robot"]
    assert three_d["topics"]["/robot_description"]["visible"] is True
    shown = {t for t, c in three_d["topics"].items() if c.get("visible")}
    shown |= {config["Image!camera"]["imageMode"]["imageTopic"], config["RosOut!log"]["topicToRender"]}
    assert shown <= set(schemas)
    assert three_d["followTf"] in urdf.link_map
