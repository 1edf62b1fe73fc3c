"""Gait planning with placo's walk pattern generator (LIPM/ZMP preview over planned footsteps).

`GaitPlannerCore` owns placo's `WalkPatternGenerator` and its current trajectory, and answers three requests:
start walking from standing, replan at a future time with a new per-step displacement, and stop (two steps in
place, then stand). Each answer is a `GaitSegment`: the trajectory sampled at the control period from the
replanning time on, in plain numpy arrays. Sampling makes the plan a value that crosses a process boundary, so
the ~5 ms replanning (placo holds the GIL while it plans) runs in its own process and never stalls the 100 Hz
control loop (`robot.control.gait_process`).
"""

from __future__ import annotations

import contextlib
import hashlib
import math
import os
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import placo

from robot.control.clamp import clamp
from robot.model import humanoid_v1
from robot.user_cache import user_cache_dir

# Walk parameters measured to walk this robot in MuJoCo (shared FINDINGS.md): single support 0.3 s, no double
# support, CoM 0.23 m, foot rise 0.025 m, trunk upright.
SINGLE_SUPPORT_S = 0.30
SINGLE_SUPPORT_TIMESTEPS = 10
COM_HEIGHT_M = 0.23
FOOT_RISE_M = 0.025
FEET_SPACING_M = 0.10
PLANNED_TIMESTEPS = 48
FOOTSTEPS_AHEAD = 8  # placo's repetitive footstep planner; cost grows fast above 10
# Per-step limits (m, rad): with 0.3 s steps, 0.06 m is 0.2 m/s forward as planned, but the real steps fall about a
# fifth short (servo lag), so the robot walks at most ~0.16 m/s. 0.075 m reached 0.2 m/s, and fell once in 30 tasks.
MAX_STEP_FORWARD_M = 0.06
MAX_STEP_BACKWARD_M = 0.04
MAX_STEP_SIDE_M = 0.03
# Turning in place the feet slip round: 0.3 rad a step gave 0.45 rad/s for 0.6 asked, 0.45 rad gave 0.55 rad/s with
# the arms hanging and 0.46 with them held back (stop 64), 0.65 rad gives 0.52 (`humanoid bench walk` scripts 0-19:
# 0 falls either way, tracking 7.9 % and max tilt 13.6 degrees against 8.0 % and 12.8).
MAX_STEP_TURN_RAD = 0.65
# How far ahead of the replanning time a segment is sampled (s): replans come every 0.1 s, so this leaves slack.
SEGMENT_HORIZON_S = 1.0
# Natural frequency of the linear inverted pendulum at the walking CoM height (1/s).
OMEGA = math.sqrt(9.81 / COM_HEIGHT_M)


def walk_parameters() -> placo.HumanoidParameters:
    p = placo.HumanoidParameters()
    p.single_support_duration = SINGLE_SUPPORT_S
    p.single_support_timesteps = SINGLE_SUPPORT_TIMESTEPS
    p.double_support_ratio = 0.0
    p.startend_double_support_ratio = 1.5
    p.planned_timesteps = PLANNED_TIMESTEPS
    p.walk_com_height = COM_HEIGHT_M
    p.walk_foot_height = FOOT_RISE_M
    p.walk_trunk_pitch = 0.0
    p.walk_foot_rise_ratio = 0.2
    p.foot_length = humanoid_v1.FOOT_LENGTH
    p.foot_width = humanoid_v1.FOOT_WIDTH
    p.feet_spacing = FEET_SPACING_M
    p.zmp_margin = 0.02
    p.foot_zmp_target_x = 0.0
    p.foot_zmp_target_y = 0.0
    p.walk_max_dtheta = MAX_STEP_TURN_RAD
    p.walk_max_dy = MAX_STEP_SIDE_M
    p.walk_max_dx_forward = MAX_STEP_FORWARD_M
    p.walk_max_dx_backward = MAX_STEP_BACKWARD_M
    return p


def placo_model_dir() -> Path:
    """Where robots keep their placo model: a per-user cache, not a directory per process, so that a robot process
    killed outright leaves nothing behind."""
    return user_cache_dir("placo")


def write_placo_model(directory: Path | None = None) -> Path:
    """Write the placo model derived from humanoid_v1 (placo loads from a file path). The file is named by its
    content and written whole (a rename), so processes running different versions never read each other's model
    or half a file."""
    if directory is None:
        try:
            return write_placo_model(placo_model_dir())
        except OSError:  # no writable home (a service account): the temporary directory, one per user
            return write_placo_model(Path(tempfile.gettempdir()) / f"humanoid-placo-{os.getuid()}")
    directory.mkdir(parents=True, exist_ok=True)
    text = humanoid_v1.placo_mjcf()
    digest = hashlib.sha256(text.encode()).hexdigest()[:16]
    path = directory / f"{humanoid_v1.MODEL_NAME}_placo_{digest}.xml"
    if not path.is_file():  # named by its content and only ever written whole: one there is the right one
        partial = directory / f".{path.name}.{os.getpid()}.{threading.get_ident()}"
        partial.write_text(text)
        os.replace(partial, path)
    return path


@contextlib.contextmanager
def native_stdout_silenced() -> Iterator[None]:
    """placo's C++ prints "Loading model" to the process's stdout, which must stay clean (`humanoid run --json`)."""
    sys.stdout.flush()
    saved = os.dup(1)
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)
        os.close(devnull)


def load_placo_robot(model_path: Path) -> placo.HumanoidRobot:
    """placo's model of humanoid_v1, its joints set to the standing posture.

    The IK must start from bent knees: from placo's neutral state (all zeros) the knees sit on their singularity,
    and the right knee, which bends negative, gets pushed onto its +0.05 rad stop and stays there (a straight
    right leg, a bent left one: the robot stood 6 degrees tilted and walked lopsided).
    """
    with native_stdout_silenced():
        robot = placo.HumanoidRobot(str(model_path), placo.Flags.mjcf)
    put_at_walk_start(robot)
    return robot


# placo's reach_initial_pose nudges the joints towards random configurations (C's rand(), one generator for the
# whole process) to leave singularities; seeded before each call, every walk starts from the same pose whatever the
# process ran before (unseeded, a walk test's yaw error went from 0.014 to 0.14 rad after two earlier walks).
INITIAL_POSE_SEED = 1


def reach_initial_pose(
    tasks: placo.WalkTasks, feet_spacing: float, com_height: float, trunk_pitch: float = 0.0
) -> None:
    """placo's `WalkTasks.reach_initial_pose` at the origin, made reproducible (see INITIAL_POSE_SEED)."""
    placo.seed(INITIAL_POSE_SEED)
    tasks.reach_initial_pose(np.eye(4), feet_spacing, com_height, trunk_pitch)


def put_at_walk_start(robot: placo.HumanoidRobot) -> None:
    """The model exactly as at start-up: standing posture, base and support frame at the origin, both feet down.

    After a walk placo keeps the last support frame, and the first re-anchoring on a support foot in the next walk
    then jerked the hip rolls by 0.3 rad in 0.1 s: most falls in the walk benchmark were 1-2 s into a walk started
    from standing after earlier walks.
    """
    for name, value in humanoid_v1.stand_posture().items():
        robot.set_joint(name, value)
    robot.set_T_world_fbase(np.eye(4))
    robot.set_T_world_support(np.eye(4))
    robot.support_is_both = True
    robot.update_kinematics()


@dataclass(frozen=True)
class StepCommand:
    """Displacement per step in the robot's frame: forward, left (m) and turn (rad)."""

    dx: float = 0.0
    dy: float = 0.0
    dtheta: float = 0.0

    def clipped(self) -> StepCommand:
        return StepCommand(
            clamp(self.dx, -MAX_STEP_BACKWARD_M, MAX_STEP_FORWARD_M),
            clamp(self.dy, -MAX_STEP_SIDE_M, MAX_STEP_SIDE_M),
            clamp(self.dtheta, -MAX_STEP_TURN_RAD, MAX_STEP_TURN_RAD),
        )


@dataclass(frozen=True)
class Footstep:
    """A planned support foot placement in the planner's world frame: side, x, y, yaw."""

    side: str
    x: float
    y: float
    yaw: float


@dataclass
class GaitSegment:
    """A planned trajectory sampled every `dt` from `t_start` (planner time, s).

    Arrays have one row per sample: feet (n, 4, 4), com (n, 3), trunk rotation (n, 3, 3), zmp and dcm (n, 2),
    support (n,) with 0 = double support, 1 = left foot, 2 = right foot. `ends_standing` marks the last segment
    of a stop: after it the robot stands on both feet.
    """

    t_start: float
    dt: float
    left: np.ndarray
    right: np.ndarray
    com: np.ndarray
    trunk: np.ndarray
    zmp: np.ndarray
    dcm: np.ndarray
    support: np.ndarray
    footsteps: list[Footstep] = field(default_factory=list)
    ends_standing: bool = False
    plan_ms: float = 0.0

    @property
    def t_end(self) -> float:
        return self.t_start + (len(self.com) - 1) * self.dt

    def index(self, t: float) -> int:
        return int(min(max(round((t - self.t_start) / self.dt), 0), len(self.com) - 1))


_SIDES = {"left": 1, "right": 2}


def _yaw(matrix: np.ndarray) -> float:
    return math.atan2(matrix[1, 0], matrix[0, 0])


def _first_flying_side(command: StepCommand) -> placo.HumanoidRobot_Side:
    """The foot that leads towards the motion: stepping right with the left foot first makes the left foot cross
    over to the right one (the feet collided and the robot fell in 3 of 20 benchmark scripts)."""
    lateral = command.dy if abs(command.dy) > 1e-4 else command.dtheta
    return placo.HumanoidRobot_Side.right if lateral < 0 else placo.HumanoidRobot_Side.left


class GaitPlannerCore:
    """placo's walk pattern generator and the current trajectory; single-threaded, no I/O."""

    def __init__(self, model_path: Path, dt: float, horizon_s: float = SEGMENT_HORIZON_S) -> None:
        self.dt = dt
        self.horizon_s = horizon_s
        self.parameters = walk_parameters()
        self.robot = load_placo_robot(model_path)
        self._solver = placo.KinematicsSolver(self.robot)
        self._tasks = placo.WalkTasks()
        self._tasks.initialize_tasks(self._solver, self.robot)
        self._trajectory: placo.WPGTrajectory | None = None
        self._last_replan = 0.0
        self.reset_standing()

    def reset_standing(self) -> None:
        """Put the planner's robot in the standing pose at the origin (the start of every walk)."""
        p = self.parameters
        put_at_walk_start(self.robot)
        reach_initial_pose(self._tasks, p.feet_spacing, p.walk_com_height, p.walk_trunk_pitch)
        # Fresh generators: placo's keep state from the previous plan, which would bend the next start.
        self._footsteps = placo.FootstepsPlannerRepetitive(p)
        self._walk = placo.WalkPatternGenerator(self.robot, p)
        self._trajectory = None

    def start(self, command: StepCommand, t: float) -> GaitSegment:
        """Plan a walk from standing still, beginning at planner time `t`."""
        self.reset_standing()
        return self._plan(command, t)

    def replan(self, command: StepCommand, t: float) -> GaitSegment:
        """Replan the footsteps ahead with a new per-step command, continuing the current trajectory at `t`."""
        if self._trajectory is None:
            return self.start(command, t)
        trajectory = self._trajectory
        if not self._walk.can_replan_supports(trajectory, t):
            # placo cannot change the supports at this instant (e.g. at the end of the plan): keep the old one
            return self._sample(trajectory, t, ends_standing=False, plan_ms=0.0)
        c = command.clipped()
        self._footsteps.configure(c.dx, c.dy, c.dtheta, FOOTSTEPS_AHEAD)

        started = time.perf_counter()
        supports = self._walk.replan_supports(self._footsteps, trajectory, t, self._last_replan)
        self._trajectory = self._walk.replan(supports, trajectory, t)
        self._last_replan = t
        return self._sample(self._trajectory, t, ends_standing=False, plan_ms=(time.perf_counter() - started) * 1e3)

    def stop(self, t: float) -> GaitSegment:
        """Two steps in place, then stand on both feet; the segment runs to the end of the trajectory. When placo
        cannot change the supports at this instant, the walk goes on as planned (`ends_standing` False) and the
        caller asks again: stopping at the end of the old plan instead walked its 8 steps ahead at the last speed,
        about 2 s and several cm past where the robot was told to stop."""
        if self._trajectory is None:
            raise RuntimeError("not walking")
        trajectory = self._trajectory
        if not self._walk.can_replan_supports(trajectory, t):
            return self._sample(trajectory, t, ends_standing=False, plan_ms=0.0)
        started = time.perf_counter()
        self._footsteps.configure(0.0, 0.0, 0.0, 2)
        supports = self._walk.replan_supports(self._footsteps, trajectory, t, self._last_replan)
        self._trajectory = trajectory = self._walk.replan(supports, trajectory, t)
        self._last_replan = t
        segment = self._sample(
            trajectory,
            t,
            ends_standing=True,
            plan_ms=(time.perf_counter() - started) * 1e3,
            horizon=trajectory.t_end - t,
        )
        return segment

    # --------------------------------------------------------------------------------------------------------

    def _plan(self, command: StepCommand, t: float) -> GaitSegment:

        started = time.perf_counter()
        c = command.clipped()
        self._footsteps.configure(c.dx, c.dy, c.dtheta, FOOTSTEPS_AHEAD)
        left = placo.flatten_on_floor(self.robot.get_T_world_left())
        right = placo.flatten_on_floor(self.robot.get_T_world_right())
        footsteps = self._footsteps.plan(_first_flying_side(c), left, right)
        supports = placo.FootstepsPlanner.make_supports(footsteps, t, True, self.parameters.has_double_support(), True)
        self._trajectory = self._walk.plan(supports, self.robot.com_world(), t)
        self._last_replan = t
        return self._sample(self._trajectory, t, ends_standing=False, plan_ms=(time.perf_counter() - started) * 1e3)

    def _sample(
        self,
        trajectory: placo.WPGTrajectory,
        t0: float,
        ends_standing: bool,
        plan_ms: float,
        horizon: float | None = None,
    ) -> GaitSegment:
        t_end = min(trajectory.t_end, t0 + (self.horizon_s if horizon is None else horizon))
        n = max(1, math.floor((t_end - t0) / self.dt + 1e-9) + 1)
        left = np.empty((n, 4, 4))
        right = np.empty((n, 4, 4))
        com = np.empty((n, 3))
        trunk = np.empty((n, 3, 3))
        zmp = np.empty((n, 2))
        dcm = np.empty((n, 2))
        support = np.empty(n, dtype=np.int8)
        for i in range(n):
            t = t0 + i * self.dt
            left[i] = trajectory.get_T_world_left(t)
            right[i] = trajectory.get_T_world_right(t)
            com[i] = trajectory.get_p_world_CoM(t)
            trunk[i] = trajectory.get_R_world_trunk(t)
            zmp[i] = trajectory.get_p_world_ZMP(t, OMEGA)[:2]
            dcm[i] = trajectory.get_p_world_DCM(t, OMEGA)[:2]
            support[i] = 0 if trajectory.support_is_both(t) else _SIDES[str(trajectory.support_side(t))]
        footsteps = []
        for s in trajectory.get_supports():
            if s.is_both():
                continue
            frame = s.frame()
            footsteps.append(Footstep(str(s.side()), float(frame[0, 3]), float(frame[1, 3]), _yaw(frame)))
        return GaitSegment(t0, self.dt, left, right, com, trunk, zmp, dcm, support, footsteps, ends_standing, plan_ms)
