"""The topics a session or the live robot publishes for Foxglove and Lichtblick, with their schemas: one set of
channels per foxglove.Context (an export's file, or the live server)."""

from __future__ import annotations

import foxglove
from foxglove.channels import (
    CompressedImageChannel,
    FrameTransformsChannel,
    GridChannel,
    ImageAnnotationsChannel,
    JointStatesChannel,
    LaserScanChannel,
    LogChannel,
    SceneUpdateChannel,
)

# std_msgs/String, as Foxglove's and Lichtblick's URDF layer reads /robot_description (JSON-encoded: {"data": urdf})
ROBOT_DESCRIPTION_SCHEMA = {
    "title": "std_msgs/String",
    "type": "object",
    "properties": {"data": {"type": "string", "description": "the robot's URDF"}},
}
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

ROBOT_DESCRIPTION = "/robot_description"
TF = "/tf"
JOINT_STATES = "/joint_states"
CAMERA = "/camera/image/compressed"
SCAN = "/scan"
MAP = "/map"
LOG = "/log"


class FoxgloveChannels:
    """Every channel, registered on `context`."""

    def __init__(self, context: foxglove.Context) -> None:
        self.description = foxglove.Channel(ROBOT_DESCRIPTION, schema=ROBOT_DESCRIPTION_SCHEMA, context=context)
        self.tf = FrameTransformsChannel(TF, context=context)
        self.scene = SceneUpdateChannel("/scene", context=context)
        self.joints = JointStatesChannel(JOINT_STATES, context=context)
        self.targets = JointStatesChannel("/joint_targets", context=context)
        self.telemetry = foxglove.Channel("/telemetry", schema=TELEMETRY_SCHEMA, context=context)
        self.camera = CompressedImageChannel(CAMERA, context=context)
        self.annotations = ImageAnnotationsChannel("/camera/annotations", context=context)
        self.scan = LaserScanChannel(SCAN, context=context)
        self.map = GridChannel(MAP, context=context)
        self.log = LogChannel(LOG, context=context)
        self.plans = foxglove.Channel("/plans", schema=PLAN_SCHEMA, context=context)
