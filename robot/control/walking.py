"""The walking state machine: standing -> starting -> walking -> stopping -> standing.

Each control tick it advances its own gait clock, asks the gait planner for a new segment every `REPLAN_PERIOD_S`
(due `PLAN_LEAD_S` ahead, so a planner in another process answers before the segment is needed), and tracks the
current segment with whole-body IK. A zero command stops the walk with two steps in place; a new command after a
stop starts again from standing.

Headless (`wait_for_plans`), a due plan is waited for: the walk is the same on every run. In real time a plan that
is late (a busy machine) is taken when it arrives: the walk carries on along the current segment, which reaches
`SEGMENT_HORIZON_S` ahead, and a walk that is starting stands until its first plan. It waits only when the current
segment is about to run out.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum
from typing import Protocol

import numpy as np

from robot.control.gait import Footstep, GaitSegment, StepCommand
from robot.control.whole_body import WholeBodyIK

REPLAN_PERIOD_S = 0.1
PLAN_LEAD_S = 0.05
# In real time, a late plan is waited for only when the current segment has less than this left (s).
RUN_OUT_MARGIN_S = 0.1
# Per-step displacements smaller than these count as "stand still" (m, rad).
STILL_STEP_M = 0.002
STILL_STEP_RAD = 0.005


class GaitPlanner(Protocol):
    """Asynchronous gait planning: `request()` returns at once; `result()` gives the segment (blocking if asked)."""

    def request(self, kind: str, command: StepCommand, t: float) -> None: ...

    def result(self, block: bool) -> GaitSegment | None: ...

    def forget(self) -> None:
        """The outstanding answer is not wanted any more (dropped when it comes, without waiting for it)."""

    def close(self) -> None: ...


class WalkPhase(StrEnum):
    STANDING = "standing"
    STARTING = "starting"
    WALKING = "walking"
    STOPPING = "stopping"


@dataclass(frozen=True)
class PlanLateness:
    """Walk plans that came after they were due (in real time, a planner short of CPU): how many since the walk
    controller was made, and their lateness summed (gait time, s), so a reader can take the rate over a window."""

    late_plans: int = 0
    late_s_total: float = 0.0


@dataclass(frozen=True)
class GaitView:
    """What a viewer shows of the walk: the footsteps ahead, CoM and ZMP (planner frame), and the phase."""

    phase: WalkPhase
    footsteps: tuple[Footstep, ...]
    com: tuple[float, float, float]
    zmp: tuple[float, float]
    support_foot: str  # "left" | "right" | "both"


def _is_still(c: StepCommand) -> bool:
    return abs(c.dx) < STILL_STEP_M and abs(c.dy) < STILL_STEP_M and abs(c.dtheta) < STILL_STEP_RAD


class WalkingController:
    def __init__(self, planner: GaitPlanner, ik: WholeBodyIK, dt: float, wait_for_plans: bool = True) -> None:
        self.planner = planner
        self.wait_for_plans = wait_for_plans
        self.ik = ik
        self.dt = dt
        self.phase = WalkPhase.STANDING
        self.ready_targets = ik.reset_standing()
        self._command = StepCommand()
        self._t = 0.0
        self._segment: GaitSegment | None = None
        self._pending_at: float | None = None
        self._last_request = 0.0
        self._targets = self.ready_targets.copy()
        self.stepped = False  # a foot has left the ground since this walk started
        self.lateness = PlanLateness()

    @property
    def active(self) -> bool:
        """True while the walk drives the joints (from the first planned step to standing again)."""
        return self.phase != WalkPhase.STANDING

    def set_step_command(self, command: StepCommand) -> None:
        self._command = command.clipped()

    def abort(self) -> None:
        """Forget the walk at once (e-stop, fall, reset): the caller takes over the joints."""
        self.phase = WalkPhase.STANDING
        self._segment = None
        if self._pending_at is not None:
            self.planner.forget()  # the next request is not confused with it, and the stop does not wait for it
        self._pending_at = None

    def update(self) -> np.ndarray | None:
        """Joint targets for this tick, or None when standing (the caller holds the posture)."""
        t = self._t
        if self.phase == WalkPhase.STANDING:
            if _is_still(self._command):
                return None
            self._t = t = 0.0
            self.stepped = False
            self._targets = self.ik.reset_standing()
            self._request("start", t + PLAN_LEAD_S)
            self.phase = WalkPhase.STARTING
        if self._pending_at is not None and t >= self._pending_at - 1e-9:
            segment = self.planner.result(block=self._must_wait(t))
            if segment is None:  # late, in real time: carry on along the current segment
                if self.phase == WalkPhase.STARTING:
                    return self._targets.copy()  # stand, the gait clock held, until the first plan comes
                return self._track(t)
            if t - self._pending_at > 1e-9:  # the walk carried on along its last segment for a tick or more
                late = self.lateness
                self.lateness = PlanLateness(late.late_plans + 1, late.late_s_total + t - self._pending_at)
            self._segment = segment
            self._pending_at = None
            if self.phase == WalkPhase.STARTING:
                self.phase = WalkPhase.WALKING
            elif self.phase == WalkPhase.STOPPING and not segment.ends_standing:
                self.phase = WalkPhase.WALKING  # the planner could not stop at that instant: ask again next period
        if self.phase == WalkPhase.WALKING and self._pending_at is None and t - self._last_request >= REPLAN_PERIOD_S:
            if _is_still(self._command):
                self._request("stop", t + PLAN_LEAD_S)
                self.phase = WalkPhase.STOPPING
            else:
                self._request("replan", t + PLAN_LEAD_S)
        return self._track(t)

    def _must_wait(self, t: float) -> bool:
        """Whether a due plan must be waited for now: always headless; in real time, once the walk would run out."""
        if self.wait_for_plans:
            return True
        segment = self._segment
        return segment is not None and t >= segment.t_end - RUN_OUT_MARGIN_S

    def _track(self, t: float) -> np.ndarray:
        """This tick's targets along the current segment; the gait clock moves on a tick."""
        segment = self._segment
        if segment is not None:
            i = segment.index(t)
            self.stepped = self.stepped or bool(segment.support[i])
            self._targets = self.ik.track(segment, i)
            if self.phase == WalkPhase.STOPPING and segment.ends_standing and t >= segment.t_end - 1e-9:
                self.phase = WalkPhase.STANDING
                self._segment = None
        self._t = t + self.dt
        return self._targets.copy()

    def swing_leg(self) -> str | None:
        """The leg in the air at the current gait sample ("left"/"right"), or None in double support or standing."""
        segment = self._segment
        if segment is None:
            return None
        support = int(segment.support[segment.index(self._t - self.dt)])
        return {1: "right", 2: "left"}.get(support)

    def view(self) -> GaitView | None:
        segment = self._segment
        if segment is None:
            return None
        i = segment.index(self._t - self.dt)
        support = {0: "both", 1: "left", 2: "right"}[int(segment.support[i])]
        com = segment.com[i]
        return GaitView(
            self.phase,
            tuple(segment.footsteps),
            (float(com[0]), float(com[1]), float(com[2])),
            (float(segment.zmp[i, 0]), float(segment.zmp[i, 1])),
            support,
        )

    def _request(self, kind: str, at: float) -> None:
        self.planner.request(kind, self._command, at)
        self._pending_at = at
        self._last_request = at - PLAN_LEAD_S
