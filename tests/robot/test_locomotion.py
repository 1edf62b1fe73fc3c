"""Locomotion in physics: the biped walks on the simulated servos with IMU balance feedback."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robot.control.balance import TrunkTilt
from robot.control.gait import write_placo_model
from robot.control.locomotion import Velocity, VelocityLimits, VelocityShaper
from robot.control.stack import build_locomotion, measured_pose, sensors
from robot.control.walk_trial import ScriptSegment, run_trial
from robot.control.walking import WalkPhase
from robot.control.whole_body import WholeBodyIK
from robot.model import humanoid_v1
from robot.model.world import open_floor
from robot.sim.backend import MujocoSimBackend

DT = 0.01


def test_velocity_is_clipped_and_rate_limited() -> None:
    shaper = VelocityShaper(VelocityLimits(vx_forward=0.2, accel=0.3))
    accepted = shaper.set_target(Velocity(vx=5.0, yaw_rate=-9.0))
    assert accepted.vx == 0.2 and accepted.yaw_rate == -VelocityLimits().yaw_rate
    speeds = [shaper.update(DT).vx for _ in range(100)]
    assert np.all(np.diff(speeds) <= 0.3 * DT + 1e-12)  # never faster than the acceleration limit
    assert speeds[-1] == pytest.approx(0.2)
    with pytest.raises(ValueError):
        shaper.set_target(Velocity(vx=float("nan")))


def test_stands_balanced_in_the_walk_ready_posture(layout, scene_model, tmp_path) -> None:
    """Standing still under the locomotion controller (IMU feedback on): upright, symmetric, on both feet."""
    sim = MujocoSimBackend(layout, scene_model)
    loco = build_locomotion(sim, tmp_path, planner_process=False)
    stand = loco.stand_targets
    names = humanoid_v1.JOINT_NAMES
    # the IK's stance is symmetric (a knee stuck on its stop once made the robot stand 6 degrees tilted)
    assert stand[names.index("l_knee")] == pytest.approx(-stand[names.index("r_knee")], abs=1e-3)
    sim.reset(stand)
    start = sim.read()
    for _ in range(300):
        sim.write(loco.update(sensors(sim.read()), stand))
        sim.step(DT)
    end = sim.read()
    assert loco.phase == WalkPhase.STANDING
    assert not end.fallen and end.tilt_deg < 2.0
    assert np.linalg.norm(end.base_position[:2] - start.base_position[:2]) < 0.01
    left, right = end.foot_forces.sum(axis=1)
    assert left > 10.0 and right > 10.0 and abs(left - right) < 5.0  # weight shared by both feet


def _walk(script: list[ScriptSegment], tmp_path):
    sim = MujocoSimBackend(open_floor())
    loco = build_locomotion(sim, tmp_path, planner_process=False)
    return run_trial(script, sim, loco), sim, loco


def test_walks_a_20_s_script_upright_and_follows_it(tmp_path) -> None:
    """Forward, sideways, turning and backward in one script: never falls, ends where the command said."""
    script = [
        ScriptSegment(5.0, Velocity(vx=0.1)),
        ScriptSegment(4.0, Velocity(vy=0.04)),
        ScriptSegment(4.0, Velocity(yaw_rate=0.5)),
        ScriptSegment(4.0, Velocity(vx=-0.08)),
        ScriptSegment(2.0, Velocity()),
    ]
    result, sim, loco = _walk(script, tmp_path)
    assert not result.fell
    assert result.max_tilt_deg < 20.0
    assert result.commanded_distance_m > 0.9
    assert result.tracking_error < 0.2  # final position within 20 % of the commanded path length
    assert abs(result.yaw_error_rad) < 0.2
    assert loco.phase == WalkPhase.STANDING  # stopped at the end of the script
    # leg odometry (encoders, IMU, foot pads) agrees with the simulator's ground truth
    estimate, truth = loco.odometry.pose, sim.read().base_position
    assert np.hypot(estimate.x - truth[0], estimate.y - truth[1]) < 0.1


def test_walking_keeps_the_trunk_upright_and_only_the_feet_on_the_floor(tmp_path) -> None:
    """The trunk sagged towards the swinging leg in every single support (12 degrees peak to peak) and the hand on
    the low side dragged on the floor in every walk; the stance leg now levels it at the hip."""
    sim = MujocoSimBackend(open_floor())
    loco = build_locomotion(sim, tmp_path, planner_process=False)
    sim.reset(loco.stand_targets)
    m = sim.read()
    loco.reset_odometry(measured_pose(m), sensors(m))
    model, data = sim.model, sim.data
    feet = {model.body(name).id for name in humanoid_v1.FOOT_BODIES.values()}
    floor = {g for g in range(model.ngeom) if model.geom_bodyid[g] == 0}
    rolls, on_the_floor = [], set()
    for velocity in (Velocity(vx=0.12), Velocity(vy=0.04), Velocity(yaw_rate=0.5), Velocity(vx=-0.08)):
        loco.set_velocity(velocity)
        for tick in range(400):
            sim.write(loco.update(sensors(sim.read()), loco.stand_targets))
            sim.step(DT)
            for contact in data.contact[: data.ncon]:
                if contact.geom1 in floor or contact.geom2 in floor:
                    body = int(model.geom_bodyid[contact.geom2 if contact.geom1 in floor else contact.geom1])
                    if body not in feet:
                        on_the_floor.add(model.body(body).name)
            if tick >= 100:  # under way
                rolls.append(math.degrees(TrunkTilt.from_quat(sim.read().imu_quat).roll))
    assert not sim.read().fallen
    assert on_the_floor == set()
    assert np.percentile(rolls, 99) - np.percentile(rolls, 1) < 5.0


@pytest.mark.parametrize("vy", [0.05, -0.05])
def test_sideways_walking_goes_the_commanded_way(tmp_path, vy: float) -> None:
    """Open loop this robot once drifted the wrong way sideways: the bar to beat."""
    result, sim, _ = _walk([ScriptSegment(6.0, Velocity(vy=vy)), ScriptSegment(1.5, Velocity())], tmp_path)
    assert not result.fell
    sideways = sim.read().base_position[1]  # the open floor starts the robot at the origin facing +x
    assert np.sign(sideways) == np.sign(vy) and abs(sideways) > 0.2
    # The end within 30 % of the path: 0.232 and 0.235 open loop before the no-slip pass (stop 68), 0.235 and 0.256
    # with it, the sideways distance unchanged (0.26 m of 0.30); the walk is closed loop wherever it is used.
    assert result.tracking_error < 0.3


def test_turns_in_place_at_most_of_the_rate_navigation_asks_for(tmp_path) -> None:
    """Navigation turns in place at 0.6 rad/s: with 0.3 rad a step the robot managed only 0.45 rad/s (its feet slip
    round), and every turn toward a path or a table took a second longer than planned."""
    sim = MujocoSimBackend(open_floor())
    loco = build_locomotion(sim, tmp_path, planner_process=False)
    sim.reset(loco.stand_targets)
    m = sim.read()
    loco.reset_odometry(measured_pose(m), sensors(m))
    loco.set_velocity(Velocity(yaw_rate=0.6))
    turned, previous, turned_at_3_s = 0.0, m.yaw_rad, 0.0
    for tick in range(1, 801):
        sim.write(loco.update(sensors(sim.read()), loco.stand_targets))
        sim.step(DT)
        m = sim.read()
        turned += math.remainder(m.yaw_rad - previous, math.tau)
        previous = m.yaw_rad
        if tick == 300:
            turned_at_3_s = turned
    assert not m.fallen and m.tilt_deg < 15.0
    assert np.hypot(*m.base_position[:2]) < 0.1  # in place
    assert (turned - turned_at_3_s) / 5.0 > 0.5  # rad/s, once under way


def test_a_walk_is_the_same_whatever_the_process_ran_before(tmp_path) -> None:
    """placo starts each walk's pose with random nudges from one process-wide generator: unseeded, a walk test
    passed alone and failed after other walk tests in the same process (yaw error 0.014 -> 0.2 rad)."""
    script = [ScriptSegment(2.0, Velocity(vx=0.1, yaw_rate=0.3))]
    first, sim_first, _ = _walk(script, tmp_path / "first")
    for _ in range(3):  # each start draws from the generator
        WholeBodyIK(write_placo_model(tmp_path / "other"), DT)
    second, sim_second, _ = _walk(script, tmp_path / "second")
    assert first.yaw_error_rad == second.yaw_error_rad
    assert np.array_equal(sim_first.read().base_position, sim_second.read().base_position)


def test_a_tick_without_an_imu_reading_leaves_the_pose_and_the_balance_as_they_were(layout, scene_model, tmp_path):
    """A real robot's IMU can miss a tick (NaN): the legs' estimate holds and the ankles get no correction from it,
    instead of a NaN pose the map would keep and NaN goals for the servos."""
    sim = MujocoSimBackend(layout, scene_model)
    loco = build_locomotion(sim, tmp_path, planner_process=False)
    stand = loco.stand_targets
    sim.reset(stand)
    m = sim.read()
    loco.reset_odometry(measured_pose(m), sensors(m))
    for _ in range(20):
        sim.write(loco.update(sensors(sim.read()), stand))
        sim.step(DT)
    before = loco.odometry.pose
    blind = sensors(sim.read())
    blind = type(blind)(blind.joint_positions, np.full(4, np.nan), np.full(3, np.nan), blind.foot_forces)
    targets = loco.update(blind, stand)
    assert np.isfinite(targets).all()
    assert loco.odometry.pose == before
    for _ in range(20):  # and it goes on from there once the IMU is back
        sim.write(loco.update(sensors(sim.read()), stand))
        sim.step(DT)
    after = loco.odometry.pose
    assert math.isfinite(after.x) and math.dist((after.x, after.y), (before.x, before.y)) < 0.02


def test_the_stance_leg_is_levelled_only_with_the_arms_at_rest(tmp_path) -> None:
    """Carrying something (the arm held out) the stance-leg levelling shook the hand and an apple slipped out:
    the levelling, tuned with the arms at rest, is left out while they are not."""
    from robot.control.balance import AnkleBalance
    from robot.manipulation.grasp_plan import CARRY_ARM

    ik = WholeBodyIK(write_placo_model(tmp_path), DT)
    assert ik.arms_at_rest
    ik.set_upper_body({**humanoid_v1.stand_posture(), **CARRY_ARM})
    assert not ik.arms_at_rest
    ik.set_upper_body(humanoid_v1.stand_posture())
    assert ik.arms_at_rest

    sim = MujocoSimBackend(open_floor())
    balance = AnkleBalance(sim.joint_axes())
    targets = np.zeros(len(humanoid_v1.JOINT_NAMES))
    tilted = np.array([math.cos(0.05), math.sin(0.05), 0.0, 0.0])  # rolled 0.1 rad
    levelled = balance.correct(targets, tilted, np.zeros(3), "left")
    left_alone = balance.correct(targets, tilted, np.zeros(3), "left", level_stance=False)
    hip_roll = humanoid_v1.JOINT_NAMES.index("r_hip_roll")  # the right leg supports
    assert abs(levelled[hip_roll]) > 0.1 and left_alone[hip_roll] == 0.0
