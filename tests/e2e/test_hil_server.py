"""`humanoid serve --backend dynamixel` on the hardware-in-the-loop rig, as a process: the real-robot backend in its
own robot process, with the rig's servo bus, IMU, feet, lidar and camera, takes a command from the API and walks
the simulated robot to the place it names (the rig in lockstep: a busy machine is slower, not different)."""

from __future__ import annotations

import math
import time

import pytest

from harness.server import ServerProcess
from robot.hardware.config import save_config
from robot.hil.rig import HilRig, rig_config, rig_thresholds
from robot.model.world import generate_world

pytestmark = pytest.mark.slow

SEED = 3


def wait_until(predicate, timeout: float):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if value := predicate():
            return value
        time.sleep(0.1)
    raise AssertionError("condition not met in time")


def test_the_served_real_robot_walks_to_a_place_through_the_rig(tmp_path) -> None:
    layout = generate_world(SEED)
    with HilRig(layout, rig_config(lockstep=True), lockstep=True) as rig:
        robot_toml = tmp_path / "robot.toml"
        save_config(rig.robot_config(), robot_toml)
        env = {"HUMANOID_ROBOT_CONFIG": str(robot_toml), "HUMANOID_DEADMAN_S": "0"}
        # the rig is in lockstep: the server's robot is given the wall-clock limits a busy machine needs there
        limits = rig_thresholds(lockstep=True)
        for name in ("control_stale_s", "imu_stale_s", "camera_stale_s", "lidar_stale_s"):
            env[f"HUMANOID_DIAGNOSTICS__{name.upper()}"] = str(getattr(limits, name))
        with ServerProcess(
            tmp_path / "server", seed=SEED, extra_env=env, servo_port=rig.port_name, views=False
        ) as server:
            assert server.post("/api/torque", json={"enabled": True}).status_code == 200
            reply = server.post("/api/commands", json={"text": "go to the charging dock"})
            assert reply.status_code == 202, reply.text
            plan = wait_until(
                lambda: (p := server.get("/api/state")["plan"]) and p["state"] not in ("queued", "running") and p,
                600.0,
            )
            events = [e["message"] for e in server.get("/api/events")][-10:]
            truth = rig.truth()  # where it is in the rig's world, said with a failure (the dock pad's edge: a fall)
            where = (truth.base_position, truth.tilt_deg, server.get("/api/state")["perception"]["status"])
            assert plan["state"] == "succeeded", (plan, events, where)
            dock = next(p for p in layout.places if p.name == "charging dock").approach
            assert not truth.fallen and math.dist(truth.base_position[:2], dock[:2]) < 0.15
            # the state and the 3D view place it by its legs' estimate: where it is, as far as it can know
            pose = server.get("/api/state")["pose"]
            assert math.dist((pose["x"], pose["y"]), truth.base_position[:2]) < 0.15
