"""A walk ends in the walking controller's own posture; with the arms in the carrying pose its knees are 0.34 rad
deeper than standing. Going to the standing posture in one control tick made the robot hop and pitch 8-10 deg just
as placing began (world seed 13 fell once in 30 runs); the legs now get there at WALK_TO_STAND_SPEED_RAD_S."""

from __future__ import annotations

import itertools
import math
import time

import numpy as np
import pytest

from robot.core.arbiter import WALK_TO_STAND_SPEED_RAD_S
from robot.interface import StopTeleop, Teleop
from robot.manipulation.grasp_plan import CARRY_ARM
from robot.model import humanoid_v1

LEGS = [humanoid_v1.JOINT_NAMES.index(n) for n in humanoid_v1.JOINT_NAMES if n[2:5] in ("hip", "kne", "ank")]
# (the ankles also carry the IMU balance feedback, which comes back on, a few mrad, once the legs have arrived)
HIPS_AND_KNEES = [humanoid_v1.JOINT_NAMES.index(n) for n in humanoid_v1.JOINT_NAMES if n[2:5] in ("hip", "kne")]


def _carry(worker) -> None:
    """The arms in the carrying pose, as `pick_object` leaves them (set directly: no mug needed for the legs)."""
    targets = worker.arbiter.default_stand.copy()
    for name, value in CARRY_ARM.items():
        targets[humanoid_v1.JOINT_NAMES.index(name)] = value
    worker.arbiter.stand_with_upper_body(targets)


@pytest.mark.slow
def test_a_carrying_robot_comes_to_rest_from_a_walk_without_a_jolt(make_worker) -> None:
    worker = make_worker(realtime=False)
    written: list[tuple[bool, np.ndarray]] = []  # each tick: walking?, the joint targets sent to the servos
    write = worker.backend.write

    def record(targets: np.ndarray) -> None:
        written.append((worker.locomotion.moving, np.array(targets)))
        write(targets)

    worker.backend.write = record
    _carry(worker)
    worker.wait_for(lambda s: s.sim_time_s > 1.5, 30)
    deadline = time.monotonic() + 20
    while worker.state().sim_time_s < 4.0 and time.monotonic() < deadline:
        assert worker.submit(Teleop(vx=0.12)).accepted
        time.sleep(0.02)
    assert worker.submit(StopTeleop()).accepted
    assert worker.wait_for(lambda s: s.locomotion.phase == "standing", 60)
    stopped = worker.state().sim_time_s
    assert worker.wait_for(lambda s: s.sim_time_s > stopped + 2.0, 60)
    assert not worker.state().fallen

    last_walking = max(i for i, (walking, _) in enumerate(written) if walking)
    standing = [q for _, q in written[last_walking:]]
    jumps = [float(np.max(np.abs(b[HIPS_AND_KNEES] - a[HIPS_AND_KNEES]))) for a, b in itertools.pairwise(standing)]
    assert max(jumps) <= WALK_TO_STAND_SPEED_RAD_S * worker.dt + 0.005, f"a leg target jumped {max(jumps):.3f} rad"
    moved = float(np.max(np.abs(standing[-1][LEGS] - standing[0][LEGS])))
    assert moved > 0.1  # carrying, the walk did end in a deeper posture: the test saw the transition
    assert np.allclose(
        standing[-1][LEGS], worker.arbiter.stand[LEGS], atol=0.03
    )  # and the legs reached the standing one
    tilt = math.degrees(math.acos(float(worker.backend.data.body("body_link").xmat[8])))
    assert tilt < 5.0
