"""Room for an arm gesture: what the arm sweeps is checked on the lidar's map, and the robot turns until it is clear
(or gives the gesture up when nowhere is); on world 0, where a plant stands beside the start, the demo's waves no
longer come down on it (they overloaded the shoulder and latched the e-stop)."""

from __future__ import annotations

import math

import numpy as np

from robot.behaviours.arm_room import WAVE_SWEEP, occupied_cells, point_sweep, turn_for_room
from robot.interface import OccupancyMap
from robot.model.world import generate_world

RESOLUTION = 0.05


def grid_with(*boxes: tuple[float, float, float, float]) -> OccupancyMap:
    """A 4 x 4 m map centred on the origin, occupied in each box (x0, x1, y0, y1)."""
    size = 80
    data = np.zeros((size, size), dtype=np.int8)
    origin = (-2.0, -2.0)
    for x0, x1, y0, y1 in boxes:
        for j in range(size):
            for i in range(size):
                x, y = origin[0] + (i + 0.5) * RESOLUTION, origin[1] + (j + 0.5) * RESOLUTION
                if x0 <= x <= x1 and y0 <= y <= y1:
                    data[j, i] = 100
    return OccupancyMap(0.0, RESOLUTION, origin, size, size, data.tobytes(), 1)


def test_an_obstacle_beside_the_right_arm_blocks_a_wave_and_a_turn_clears_it() -> None:
    plant = grid_with((-0.1, 0.1, -0.5, -0.35))  # 35-50 cm to the right of a robot facing +x
    assert occupied_cells(plant, (0.0, 0.0, 0.0), WAVE_SWEEP) > 0
    turn = turn_for_room(plant, (0.0, 0.0, 0.0), WAVE_SWEEP)
    assert turn is not None and turn != 0.0
    assert occupied_cells(plant, (0.0, 0.0, turn), WAVE_SWEEP) == 0
    # the same plant on the robot's left, or the robot already turned away: nothing to do
    assert turn_for_room(plant, (0.0, 0.0, math.pi), WAVE_SWEEP) == 0.0
    assert turn_for_room(grid_with((-0.1, 0.1, 0.35, 0.5)), (0.0, 0.0, 0.0), WAVE_SWEEP) == 0.0


def test_a_chair_behind_the_right_shoulder_blocks_a_wave_rising_from_the_arm_at_rest() -> None:
    """The arm at rest is held back: the wave rises from behind the trunk (demo, world 4: it hit a chair there)."""
    chair = grid_with((-0.32, -0.22, -0.35, -0.15))
    assert occupied_cells(chair, (0.0, 0.0, 0.0), WAVE_SWEEP) > 0
    assert occupied_cells(chair, (0.0, 0.0, 0.0), point_sweep(0.0)) > 0
    turn = turn_for_room(chair, (0.0, 0.0, 0.0), WAVE_SWEEP)
    assert turn is not None and occupied_cells(chair, (0.0, 0.0, turn), WAVE_SWEEP) == 0


def _right_arm_centres(moves) -> np.ndarray:
    """The centres of the right arm's parts in the trunk's frame (x ahead, y left), every 5 % of each joint move
    from the standing posture, played through the model's kinematics."""
    import mujoco

    from robot.model import humanoid_v1

    model = humanoid_v1.build_robot_spec().compile()
    data = mujoco.MjData(model)
    trunk = model.body(humanoid_v1.TRUNK_BODY).id
    arm = ("r_sho", "r_el", "r_wrist", "r_grip", "r_finger", "r_palm")
    geoms = [g for g in range(model.ngeom) if model.body(model.geom_bodyid[g]).name.startswith(arm)]
    geoms = [g for g in geoms if model.geom_contype[g]]
    assert geoms
    posture = humanoid_v1.stand_posture()
    centres = []
    for move in moves:
        start, target = dict(posture), {**posture, **move.positions}
        for t in np.linspace(0.0, 1.0, 21):
            for name, angle in start.items():
                data.qpos[model.jnt_qposadr[model.joint(name).id]] = angle + (target[name] - angle) * t
            mujoco.mj_kinematics(model, data)
            rotation, origin = data.xmat[trunk].reshape(3, 3), data.xpos[trunk]
            centres += [rotation.T @ (data.geom_xpos[g] - origin) for g in geoms]
        posture = target
    return np.array(centres)


def test_each_sweep_holds_what_its_gesture_moves_through_from_the_arm_at_rest() -> None:
    from robot.behaviours.gestures import point_moves, wave_moves

    for sweep, moves in [(WAVE_SWEEP, wave_moves()), *((point_sweep(d), point_moves(d)) for d in (0.0, 0.5, 1.0))]:
        centres = _right_arm_centres(moves)
        assert centres[:, 0].min() > sweep.x[0] + 0.05 and centres[:, 0].max() < sweep.x[1]  # a part's radius
        assert centres[:, 1].min() > sweep.y[0] + 0.05 and centres[:, 1].max() < sweep.y[1]


def test_a_robot_boxed_in_has_no_room_and_far_things_do_not_count() -> None:
    ring = grid_with((-0.6, 0.6, -0.6, -0.3), (-0.6, 0.6, 0.3, 0.6), (-0.6, -0.3, -0.6, 0.6), (0.3, 0.6, -0.6, 0.6))
    assert turn_for_room(ring, (0.0, 0.0, 0.0), WAVE_SWEEP) is None
    far = grid_with((-0.1, 0.1, -1.2, -0.8))
    assert turn_for_room(far, (0.0, 0.0, 0.0), WAVE_SWEEP) == 0.0


def test_pointing_lower_reaches_less_far_ahead() -> None:
    counter = grid_with((0.30, 0.6, -0.5, 0.5))  # furniture 30 cm ahead
    assert occupied_cells(counter, (0.0, 0.0, 0.0), point_sweep(0.0)) > 0  # level: the hand would reach it
    assert occupied_cells(counter, (0.0, 0.0, 0.0), point_sweep(1.0)) == 0  # well below level: it stays short
    assert point_sweep(0.0).x[1] > point_sweep(0.5).x[1] > point_sweep(1.0).x[1]


def test_the_demo_beside_a_plant_turns_before_waving_and_never_touches_it() -> None:
    from harness.behaviour_judge import run_judged
    from robot.interface import BehaviourState

    layout = generate_world(0)
    plant = next(o for o in layout.obstacles if o.name.startswith("plant"))
    start = layout.robot_start
    assert math.dist((plant.x, plant.y), start[:2]) < 0.55  # the world this test is about: a plant at arm's length
    status, judge = run_judged("demo", {"listen_s": 1.0}, 0)
    touched = [c["what"] for c in judge.collisions if plant.name in c["what"]]
    assert touched == [] and status is not None
    assert status.state == BehaviourState.SUCCEEDED, status.reason
    assert any(line.startswith("greeted with a wave (turned") for line in status.feedback)
