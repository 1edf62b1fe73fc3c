"""Gait planning (placo's walk pattern generator) and the walking state machine, without physics."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

from robot.control.gait import (
    COM_HEIGHT_M,
    FEET_SPACING_M,
    MAX_STEP_FORWARD_M,
    SEGMENT_HORIZON_S,
    SINGLE_SUPPORT_S,
    GaitPlannerCore,
    StepCommand,
    write_placo_model,
)
from robot.control.gait_process import INLINE_HORIZON_S, InlineGaitPlanner, ProcessGaitPlanner
from robot.control.walking import WalkingController, WalkPhase
from robot.control.whole_body import WholeBodyIK
from robot.model import humanoid_v1

DT = 0.01


@pytest.fixture(scope="module")
def model_path(tmp_path_factory) -> Path:
    return write_placo_model(tmp_path_factory.mktemp("placo"))


@pytest.mark.parametrize(
    ("command", "axis", "per_step"),
    [(StepCommand(dx=0.03), 0, 0.03), (StepCommand(dx=-0.02), 0, -0.02), (StepCommand(dy=0.02), 1, 0.02)],
)
def test_footsteps_advance_in_the_commanded_direction(model_path, command, axis, per_step) -> None:
    core = GaitPlannerCore(model_path, DT)
    segment = core.start(command, 0.0)
    steps = [(f.x, f.y) for f in segment.footsteps]
    assert len(steps) >= 6
    # Each foot lands further along the commanded axis at every stride (two steps), by up to two step lengths.
    lefts = [s for s, f in zip(steps, segment.footsteps, strict=True) if f.side == "left"]
    deltas = np.diff(np.array(lefts)[:, axis])
    moving = deltas[np.abs(deltas) > 1e-4]
    assert moving.size >= 2
    assert np.all(np.sign(moving) == np.sign(per_step))
    assert np.all(np.abs(moving) >= abs(per_step) - 1e-3) and np.all(np.abs(moving) <= 2 * abs(per_step) + 1e-3)
    other = 1 - axis
    assert np.all(np.abs(np.diff(np.array(lefts)[:, other])) < 1e-3)  # no drift on the other axis


@pytest.mark.parametrize(
    ("command", "leading"),
    [(StepCommand(dy=0.02), "left"), (StepCommand(dy=-0.02), "right"), (StepCommand(dtheta=-0.2), "right")],
)
def test_the_foot_on_the_side_of_the_motion_steps_first(model_path, command, leading) -> None:
    """Stepping right with the left foot first would cross it over the right one (the feet collided)."""
    segment = GaitPlannerCore(model_path, DT).start(command, 0.0)
    first_single_support = int(segment.support[segment.support > 0][0])
    assert {1: "right", 2: "left"}[first_single_support] == leading  # support on one foot: the other one flies


def test_turning_rotates_the_footsteps(model_path) -> None:
    core = GaitPlannerCore(model_path, DT)
    segment = core.start(StepCommand(dtheta=0.15), 0.0)
    yaws = [f.yaw for f in segment.footsteps]
    assert yaws[-1] > 0.4  # eight steps at 0.15 rad each, minus the first in place


def test_segment_is_smooth_and_keeps_the_zmp_under_the_support_foot(model_path) -> None:
    core = GaitPlannerCore(model_path, DT)
    segment = core.start(StepCommand(dx=MAX_STEP_FORWARD_M), 0.0)
    assert segment.dt == DT and len(segment.com) > 50
    com_speed = np.linalg.norm(np.diff(segment.com, axis=0), axis=1) / DT
    assert com_speed.max() < 0.5  # m/s: no jumps
    # placo moves the ZMP between feet over one planner step (0.03 s) at the start of each single support
    support = segment.support
    settled = [i for i in np.flatnonzero(support) if i >= 4 and np.all(support[i - 4 : i + 1] == support[i])]
    assert len(settled) > 20
    for i in settled:
        foot = segment.left[i] if segment.support[i] == 1 else segment.right[i]
        local = np.linalg.inv(foot) @ np.array([*segment.zmp[i], 0.0, 1.0])
        assert abs(local[0]) <= humanoid_v1.FOOT_LENGTH / 2 + 1e-3
        assert abs(local[1]) <= humanoid_v1.FOOT_WIDTH / 2 + 1e-3


def test_replanning_continues_the_trajectory_without_a_jump(model_path) -> None:
    core = GaitPlannerCore(model_path, DT)
    first = core.start(StepCommand(dx=0.03), 0.0)
    t = 0.5
    second = core.replan(StepCommand(dx=0.03, dtheta=0.1), t)
    assert second.t_start == pytest.approx(t)
    old = first.com[first.index(t)]
    assert np.linalg.norm(second.com[0] - old) < 1e-3
    assert np.allclose(second.left[0], first.left[first.index(t)], atol=1e-3)


def test_stop_ends_standing_on_both_feet(model_path) -> None:
    core = GaitPlannerCore(model_path, DT)
    core.start(StepCommand(dx=0.03), 0.0)
    segment = core.stop(0.6)
    assert segment.ends_standing
    assert segment.support[-1] == 0
    left, right = segment.left[-1], segment.right[-1]
    assert abs(left[0, 3] - right[0, 3]) < 0.005  # feet side by side
    assert segment.t_end - 0.6 < 4 * SINGLE_SUPPORT_S + 1.0


def test_a_stop_is_short_whenever_it_is_asked_for_or_refused_until_the_next_chance(model_path) -> None:
    """Stopping used to fall back, at instants where placo cannot change the supports, on walking out the old plan
    (8 steps ahead at the last speed): about 2.5 s and 15+ cm past the stop."""
    outcomes = []
    for t in np.arange(0.40, 1.60, 0.05):
        core = GaitPlannerCore(model_path, DT)
        core.start(StepCommand(dx=0.04), 0.0)
        core.replan(StepCommand(dx=0.04), float(t) - 0.1)
        segment = core.stop(float(t))
        outcomes.append(segment.ends_standing)
        if segment.ends_standing:
            assert segment.t_end - t < 3 * SINGLE_SUPPORT_S + 0.6  # the step under way, two in place, settle
    assert any(outcomes)
    refused_in_a_row = max(len(run) for run in "".join("x" if ok else "r" for ok in outcomes).split("x"))
    assert refused_in_a_row * 0.05 < SINGLE_SUPPORT_S  # a stop asked for every period gets through within a step


def test_planner_in_a_child_process_answers_like_the_inline_one(model_path) -> None:
    child = ProcessGaitPlanner(model_path, DT)
    try:
        child.request("start", StepCommand(dx=0.03), 0.05)
        start = child.result(block=True)
        assert start is not None and start.t_start == pytest.approx(0.05)
        assert np.allclose(start.com[0], [0.0, -FEET_SPACING_M / 2, COM_HEIGHT_M], atol=1e-6)  # from standing
        child.request("replan", StepCommand(dy=0.02), 0.3)
        replanned = child.result(block=True)
        assert replanned is not None and replanned.t_start == pytest.approx(0.3)
        assert np.linalg.norm(replanned.com[0] - start.com[start.index(0.3)]) < 1e-3
        assert child.result(block=False) is None  # nothing outstanding
        # an answer no longer wanted (an e-stop) is dropped when it comes; the next request gets its own answer
        child.request("replan", StepCommand(dx=0.03), 0.4)
        child.forget()
        child.request("replan", StepCommand(dy=-0.02), 0.5)
        answer = None
        deadline = time.monotonic() + 60
        while answer is None and time.monotonic() < deadline:  # never waits: None until the answer is in
            answer = child.result(block=False)
            time.sleep(0.005)
        assert answer is not None and answer.t_start == pytest.approx(0.5)
        assert child.result(block=False) is None
        child.request("replan", StepCommand(dx=0.03), 0.6)
        child.forget()  # an answer never read when the robot stops
    finally:
        child.close()
    assert child._child.process.returncode == 0  # it exits when its pipe closes, not killed for hanging on the answer


def test_walking_controller_walks_the_kinematic_model_and_stops(model_path) -> None:
    ik = WholeBodyIK(model_path, DT)
    walk = WalkingController(InlineGaitPlanner(model_path, DT), ik, DT)
    assert walk.update() is None  # standing: nothing to do
    walk.set_step_command(StepCommand(dx=0.03))
    for _ in range(300):  # 3 s
        targets = walk.update()
        assert targets is not None and len(targets) == len(humanoid_v1.JOINT_NAMES)
        assert np.all(np.isfinite(targets))
    assert walk.phase == WalkPhase.WALKING
    travelled = ik.robot.get_T_world_frame(humanoid_v1.TRUNK_FRAME)[0, 3]
    assert travelled > 0.2  # about 0.1 m/s for 3 s, minus the start
    walk.set_step_command(StepCommand())
    for _ in range(300):
        if walk.update() is None:
            break
    assert walk.phase == WalkPhase.STANDING
    assert walk.view() is None  # nothing planned ahead while standing


def test_a_walk_after_a_turning_walk_starts_exactly_like_a_first_walk(model_path) -> None:
    """placo keeps the last support frame between walks; it jerked the hips at the next start (falls)."""
    history = [StepCommand(dtheta=-0.14)] * 500 + [StepCommand()] * 330
    restart = [StepCommand(dy=-0.014 * min(1.0, (k + 1) / 15)) for k in range(90)]

    def targets(commands: list[StepCommand]) -> np.ndarray:
        walk = WalkingController(InlineGaitPlanner(model_path, DT), WholeBodyIK(model_path, DT), DT)
        out = []
        for command in commands:
            walk.set_step_command(command)
            out.append(walk.update())
        assert walk.phase == WalkPhase.WALKING
        return np.array(out[-len(restart) + 10 :])

    assert np.allclose(targets(history + restart), targets(restart), atol=1e-4)


def test_an_inline_planner_samples_less_ahead_and_walks_exactly_the_same(model_path) -> None:
    """Headless, a plan is there when due, so the short inline segment must never run out: a start, a turn, a
    change of speed and a stop give the same joint targets as segments sampled a whole second ahead."""
    commands = (
        [StepCommand(dx=0.04)] * 120 + [StepCommand(dx=0.02, dtheta=0.2)] * 80 + [StepCommand(dy=-0.02)] * 60
    ) + [StepCommand()] * 200

    def targets(horizon_s: float) -> np.ndarray:
        walk = WalkingController(
            InlineGaitPlanner(model_path, DT, horizon_s=horizon_s), WholeBodyIK(model_path, DT), DT
        )
        out = []
        for command in commands:
            walk.set_step_command(command)
            t = walk.update()
            out.append(np.zeros(len(humanoid_v1.JOINT_NAMES)) if t is None else t)
        assert walk.phase == WalkPhase.STANDING
        return np.array(out)

    assert np.array_equal(targets(INLINE_HORIZON_S), targets(SEGMENT_HORIZON_S))


class HeldPlanner:
    """Inline planning whose answers come only when the test lets them through: a busy machine's late planner."""

    def __init__(self, model_path: Path) -> None:
        self._inline = InlineGaitPlanner(model_path, DT, horizon_s=SEGMENT_HORIZON_S)  # a process's whole segment
        self.answer = None
        self.held = True
        self.waits = 0  # results the walk blocked for
        self.forgotten = 0
        self.requested_at: list[float] = []

    def request(self, kind: str, command: StepCommand, t: float) -> None:
        assert self.answer is None, "one request at a time"
        self.requested_at.append(t)
        self._inline.request(kind, command, t)
        self.answer = self._inline.result(block=True)

    def result(self, block: bool):
        self.waits += block
        if self.held and not block:
            return None
        answer, self.answer = self.answer, None
        return answer

    def forget(self) -> None:
        self.answer = None
        self.forgotten += 1

    def close(self) -> None:
        pass


def _run(walk: WalkingController, ticks: int) -> list[np.ndarray]:
    out = []
    for _ in range(ticks):
        targets = walk.update()
        assert targets is not None and np.all(np.isfinite(targets))
        out.append(targets)
    return out


def _walking_in_real_time(model_path: Path) -> tuple[HeldPlanner, WalkingController]:
    """A real-time walk under way (0.6 s in), its planner answering on time so far."""
    planner = HeldPlanner(model_path)
    walk = WalkingController(planner, WholeBodyIK(model_path, DT), DT, wait_for_plans=False)
    walk.set_step_command(StepCommand(dx=0.03))
    planner.held = False
    _run(walk, 60)
    assert walk.phase == WalkPhase.WALKING
    return planner, walk


def test_in_real_time_a_late_plan_does_not_stall_the_walk_until_its_segment_runs_out(model_path) -> None:
    planner, walk = _walking_in_real_time(model_path)
    assert walk.lateness.late_plans == 0  # on time so far
    planner.held = True  # the planner falls 0.4 s behind: the walk goes on along the segment it has
    late = _run(walk, 40)
    assert planner.waits == 0 and planner.answer is not None  # a replan is due and not taken, nothing waited
    assert np.ptp(np.array(late), axis=0).max() > 0.01  # the legs keep moving
    asked = len(planner.requested_at)
    planner.held = False
    _run(walk, 1)
    assert len(planner.requested_at) == asked + 1  # taken as soon as it came, and the next one asked for at once
    assert planner.requested_at[-1] - planner.requested_at[-2] > 0.35
    assert walk.lateness.late_plans == 1 and 0.3 < walk.lateness.late_s_total < 0.4  # said, for diagnostics
    planner.held = True  # far behind: once the segment (1 s ahead) is about to end, the walk waits for the plan
    _run(walk, 150)
    assert planner.waits >= 1
    assert walk.phase == WalkPhase.WALKING


def test_in_real_time_a_starting_walk_stands_until_its_first_plan_then_starts_as_it_would_have(model_path) -> None:
    reference = WalkingController(InlineGaitPlanner(model_path, DT), WholeBodyIK(model_path, DT), DT)
    reference.set_step_command(StepCommand(dx=0.03))
    expected = _run(reference, 60)
    planner = HeldPlanner(model_path)
    walk = WalkingController(planner, WholeBodyIK(model_path, DT), DT, wait_for_plans=False)
    walk.set_step_command(StepCommand(dx=0.03))
    held = _run(walk, 30)
    assert walk.phase == WalkPhase.STARTING and planner.waits == 0
    assert np.allclose(held, held[0])  # standing still, not stepping off a plan it does not have
    planner.held = False
    started = _run(walk, 55)
    assert np.allclose(started, expected[5:], atol=1e-3)  # the whole start, none of it skipped (IK to 1 mrad)


def test_an_estop_while_a_plan_is_outstanding_does_not_wait_for_it(model_path) -> None:
    planner, walk = _walking_in_real_time(model_path)
    planner.held = True
    _run(walk, 20)  # a replan is outstanding
    walk.abort()
    assert planner.forgotten == 1 and planner.waits == 0 and walk.phase == WalkPhase.STANDING
    planner.held = False
    _run(walk, 60)  # and the next walk starts from its own plan
    assert walk.phase == WalkPhase.WALKING
