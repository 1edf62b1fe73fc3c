"""The right arm comes out in front when something stands where it swings out sideways: at world seed 0 a chair
stands beside the usual stance for the blue bottle, at seed 4 a plant, and the sideways swing (the hand 0.35-0.42 m
out, rising past the height of a chair) goes through them; on 12 such stances of worlds never tuned on (seeds
110-399) it went 1.5-12 cm into something, the way out in front 1.7 cm clear or more."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from robot.manipulation.arm_motion import JointMove
from robot.manipulation.grasp_plan import (
    Stance,
    arm_out_moves,
    arm_sweep_taken,
    grasp_stance_facing_any,
    stance_facings,
    stance_taken,
)
from robot.model import humanoid_v1, op3
from robot.model.scene import build_scene
from robot.model.world import generate_world

ARM_BODIES = ("r_el_link", "r_wrist_link", "r_finger_a", "r_finger_b")  # the upper arm is the shoulder's neighbour
CROWDED_SWINGS = [(0, "blue bottle"), (4, "blue bottle")]  # the usual stance free, its sideways swing taken


def stance_for(seed: int, name: str) -> tuple[Stance, object]:
    """Where the robot stands for the object on world `seed`'s map (its furniture, obstacles and walls)."""
    layout = generate_world(seed)
    counter = next(p for p in layout.places if p.name == "kitchen counter")
    thing = next(o for o in layout.objects if o.name == name)
    boxes = [*layout.furniture, *layout.obstacles]
    blocked = lambda x, y: any(b.contains(x, y) for b in boxes) or layout.in_or_beyond_walls(x, y)  # noqa: E731
    xy = (float(thing.position[0]), float(thing.position[1]))
    return grasp_stance_facing_any(xy, stance_facings(counter.approach[2], counter.surface, xy), blocked), blocked


@pytest.mark.parametrize(("seed", "name"), CROWDED_SWINGS)
def test_where_the_usual_stance_is_free_but_its_sideways_swing_is_taken_the_arm_comes_out_in_front(
    seed: int, name: str
) -> None:
    stance, blocked = stance_for(seed, name)
    counter = next(p for p in generate_world(seed).places if p.name == "kitchen counter")
    assert stance.yaw == counter.approach[2] and not stance_taken(stance, blocked)
    assert arm_sweep_taken(stance, blocked)
    assert arm_out_moves(sideways_clear=False) != arm_out_moves()
    assert [m.label for m in arm_out_moves(sideways_clear=False)][-1] == "over the surface"


class ArmSweep:
    """The robot standing (kinematics only, no physics) in world `seed`, its right arm played through moves: how
    close the arm comes to the world and to the robot's own body."""

    def __init__(self, seed: int) -> None:
        self.model = build_scene(generate_world(seed), drawn=False)
        self.data = mujoco.MjData(self.model)
        m = self.model
        robot_root = m.body_rootid[m.body("body_link").id]
        robot = [g for g in range(m.ngeom) if m.body_rootid[m.geom_bodyid[g]] == robot_root]
        arm_ids = {m.body(name).id for name in ("r_sho_roll_link", *ARM_BODIES)}
        self.arm = [g for g in robot if m.geom_bodyid[g] in arm_ids]
        self.forearm = [g for g in self.arm if m.body(m.geom_bodyid[g]).name in ARM_BODIES]
        self.body = [
            g for g in robot if m.geom_bodyid[g] not in arm_ids and m.body(m.geom_bodyid[g]).name != "r_sho_pitch_link"
        ]
        self.world = [
            g
            for g in range(m.ngeom)
            if m.body_rootid[m.geom_bodyid[g]] != robot_root
            and (m.geom_contype[g] or m.geom_conaffinity[g])
            and m.geom(g).name != "floor"
        ]

    def clearances(self, stance: Stance, moves: list) -> tuple[float, float]:
        """The least distance (m; negative: inside) of the arm from the world and of the forearm and hand from the
        body, over the moves from the standing posture, sampled every eighth of each move."""
        names = humanoid_v1.JOINT_NAMES
        joints = humanoid_v1.stand_posture()
        world = body = math.inf
        for move in moves:
            assert isinstance(move, JointMove)
            start, end = dict(joints), {**joints, **move.positions}
            for a in np.linspace(0.0, 1.0, 9)[1:]:
                self._pose(stance, {n: start[n] + a * (end[n] - start[n]) for n in names})
                world = min(world, self._distance(self.arm, self.world))
                body = min(body, self._distance(self.forearm, self.body))
            joints = end
        return world, body

    def _pose(self, stance: Stance, joints: dict[str, float]) -> None:
        m, d = self.model, self.data
        c, s = math.cos(stance.yaw), math.sin(stance.yaw)
        d.qpos[:3] = [stance.x + 0.035 * c, stance.y + 0.035 * s, op3.STAND_TRUNK_HEIGHT]  # the trunk over the feet
        d.qpos[3:7] = [math.cos(stance.yaw / 2), 0.0, 0.0, math.sin(stance.yaw / 2)]
        for name, value in joints.items():
            d.qpos[m.jnt_qposadr[m.joint(name).id]] = value
        mujoco.mj_forward(m, d)

    def _distance(self, these: list[int], those: list[int]) -> float:
        scratch = np.zeros(6)
        return min(mujoco.mj_geomDistance(self.model, self.data, g, h, 0.2, scratch) for g in these for h in those)


def nearby(stance: Stance) -> list[Stance]:
    """The stance, and the robot standing 3 cm or 0.1 rad off it (a walk ends within that)."""
    c, s = math.cos(stance.yaw), math.sin(stance.yaw)
    offsets = ((0.0, 0.0, 0.0), (0.03, 0.0, 0.0), (-0.03, 0.0, 0.0), (0.0, 0.03, 0.0), (0.0, -0.03, 0.0))
    stances = [Stance(stance.x + c * dx - s * dy, stance.y + s * dx + c * dy, stance.yaw) for dx, dy, _ in offsets]
    return [*stances, Stance(stance.x, stance.y, stance.yaw + 0.1), Stance(stance.x, stance.y, stance.yaw - 0.1)]


@pytest.mark.parametrize(("seed", "name"), CROWDED_SWINGS)
def test_the_sideways_swing_goes_into_what_stands_there_and_the_way_out_in_front_touches_nothing(
    seed: int, name: str
) -> None:
    sweep = ArmSweep(seed)
    stance, _ = stance_for(seed, name)
    sideways_world, _ = sweep.clearances(stance, arm_out_moves())
    assert sideways_world < 0.0
    world, body = sweep.clearances(stance, arm_out_moves(sideways_clear=False))
    assert world > 0.015 and body > 0.0
    for near in nearby(stance):  # 3 cm nearer the counter the hand passes its edge within a centimetre
        world, body = sweep.clearances(near, arm_out_moves(sideways_clear=False))
        assert world > -0.01 and body > 0.0, near


def test_where_the_robot_stands_at_the_grasp_the_swing_is_checked_out_to_the_open_fingers() -> None:
    """World seed 0, the apple's stance at the counter's end (a chair stands at the usual one), the east wall beside
    the sideways swing. A walk ends a few centimetres off: on a busy machine 5.5 cm nearer the wall, where the open
    fingers struck it while the check, out to the hand, said the swing was clear, and the grasp closed on nothing.
    Out to the fingertips, the check finds the wall wherever the swing would touch it, and the arm comes out in front;
    at the stance itself the swing has room."""
    stance, blocked = stance_for(0, "green apple")
    assert stance.yaw == pytest.approx(math.pi / 2)
    sweep = ArmSweep(0)
    assert sweep.clearances(stance, arm_out_moves())[0] > 0.0
    assert not arm_sweep_taken(stance, blocked, to_fingertips=True)
    touched = []
    for east in (0.01, 0.02, 0.03, 0.04, 0.055, 0.07):
        here = Stance(stance.x + east, stance.y, stance.yaw)
        if sweep.clearances(here, arm_out_moves())[0] < 0.0:
            touched.append(east)
            assert arm_sweep_taken(here, blocked, to_fingertips=True), east
    assert 0.055 in touched
    near = Stance(stance.x + 0.055, stance.y, stance.yaw)
    assert not arm_sweep_taken(near, blocked)  # out to the hand only: the check that let the fingers strike the wall


@pytest.mark.slow
def test_the_bottle_beside_the_chair_is_picked_with_the_arm_out_in_front() -> None:
    """In physics, world seed 0: the robot walks to the counter, finds the blue bottle, brings its arm out in
    front (the chair stands in the sideways swing) and holds the bottle up, the chair untouched."""
    from harness.behaviour_judge import Judge
    from robot.interface import ExecutePlan, PlanState
    from robot.sim.backend import MujocoSimBackend
    from robot.worker import RobotWorker

    layout = generate_world(0)
    backend = MujocoSimBackend(layout)
    worker = RobotWorker(layout, backend=backend, realtime=False)
    judge = Judge(backend)
    worker.start()
    try:
        steps = [
            {"action": "navigate_to", "args": {"target": "kitchen counter"}},
            {"action": "detect_object", "args": {"object": "blue bottle"}},
            {"action": "pick_object", "args": {"object": "blue bottle"}},
        ]
        assert worker.submit(ExecutePlan({"steps": steps})).accepted

        def over(state: object) -> bool:
            judge.watch(state)  # contacts as the plan runs
            return state.plan is not None and state.plan.state != PlanState.RUNNING

        assert worker.wait_for(over, 900)
        state = worker.state()
        assert state.plan.state == PlanState.SUCCEEDED, [s.detail for s in state.plan.steps]
        assert state.held_object == "blue bottle"
        assert [c["what"] for c in judge.collisions if "chair" in c["what"]] == []
    finally:
        worker.stop()


def test_a_stance_through_a_wall_the_lidar_cannot_see_is_never_room_to_stand() -> None:
    """World seed 6: the bottle at the counter's north end, a box where the feet go. The map lacks the wall behind
    the counter (the counter hides it from the lidar), and there a stance half through the wall looked free: the
    fetch walked for it and ended "path blocked" instead of saying at once that there is no room."""
    layout = generate_world(6)
    counter = next(p for p in layout.places if p.name == "kitchen counter")
    bottle = next(o for o in layout.objects if o.name == "blue bottle")
    xy = (float(bottle.position[0]), float(bottle.position[1]))
    facings = stance_facings(counter.approach[2], counter.surface, xy)
    boxes = [*layout.furniture, *layout.obstacles]
    no_walls = lambda x, y: any(b.contains(x, y) for b in boxes)  # noqa: E731
    assert not stance_taken(grasp_stance_facing_any(xy, facings, no_walls), no_walls)
    with_walls = lambda x, y: no_walls(x, y) or layout.in_or_beyond_walls(x, y)  # noqa: E731
    assert stance_taken(grasp_stance_facing_any(xy, facings, with_walls), with_walls)


def test_walls_and_what_lies_beyond_them_are_taken_and_an_open_floor_has_none() -> None:
    layout = generate_world(6)
    assert not layout.in_or_beyond_walls(0.0, 0.0) and not layout.in_or_beyond_walls(1.9, 1.45)
    assert layout.in_or_beyond_walls(1.9, 1.52) and layout.in_or_beyond_walls(2.3, 0.0)
    assert layout.in_or_beyond_walls(0.4, 1.0)  # the partition's northern half
    assert not layout.in_or_beyond_walls(0.4, 0.0)  # its doorway
    from robot.model.world import open_floor

    assert not open_floor().in_or_beyond_walls(5.0, 5.0)
