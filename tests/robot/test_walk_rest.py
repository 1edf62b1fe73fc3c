"""A walk that stops partway to let a hot servo cool: the navigator stops, rests standing and walks on; the rest
waits for the servo to cool, says so, and gives up when it does not cool."""

from __future__ import annotations

import math
import re

import pytest

from robot.interface import ExecutePlan, Fault, InjectFault, NavigationState, PlanState
from robot.navigation.navigator import NavigationFailed, Navigator
from robot.skills.walk_rest import MAX_REST_S, REST_COOL_K, ServoRest
from tests.robot.test_navigator import MappedBody, _map_with

FINISHED = (PlanState.SUCCEEDED, PlanState.FAILED, PlanState.CANCELLED)


class HotKnee:
    """A knee servo that warms while the robot walks and cools while it stands, 0.5 K a second either way."""

    hot_c = 65.0

    def __init__(self, body: MappedBody, start_c: float) -> None:
        self.body = body
        self.temperature = start_c
        self.t = body.t

    def hottest(self) -> tuple[str, float]:
        dt, self.t = self.body.t - self.t, self.body.t
        self.temperature += (0.5 if self.body.walking() else -0.5) * dt
        return "l_knee", self.temperature


class StandingRest:
    """A `WalkRest` that records whether the robot stood through each rest."""

    def __init__(self, heat: HotKnee, body: MappedBody, events: list[str]) -> None:
        self.body = body
        self.stood: list[bool] = []
        self.rest_of = ServoRest(heat, self.wait, lambda: body.t, lambda topic, message, **data: events.append(topic))

    def wait(self, seconds: float) -> None:
        self.stood.append(not self.body.walking())
        self.body.wait(seconds)

    def needed(self) -> bool:
        return self.rest_of.needed()

    def rest(self) -> None:
        self.rest_of.rest()


def test_a_walk_that_heats_a_servo_to_the_warning_stops_rests_standing_and_walks_on_to_its_goal() -> None:
    body = MappedBody(_map_with())
    heat = HotKnee(body, start_c=62.0)  # 6 s of walking to the warning
    events: list[str] = []
    rest = StandingRest(heat, body, events)
    phases: list[str] = []
    report = Navigator(body, lambda: body.t, on_update=lambda s: phases.append(s.phase), walk_rest=rest).go((1.5, 0.0))
    assert report.final_error_m < 0.1
    assert events == ["navigation/resting", "navigation/rested"]
    assert rest.stood and all(rest.stood)  # it stood all through the rest
    assert heat.hottest()[1] < HotKnee.hot_c  # and walked on cooler
    assert "resting" in phases and phases[-1] == "arrived"


def test_a_rest_waits_until_the_hottest_servo_is_well_below_the_warning_and_counts_the_time() -> None:
    body = MappedBody(_map_with())
    heat = HotKnee(body, start_c=66.0)
    rested: list[float] = []
    messages: list[str] = []
    rest = ServoRest(heat, body.wait, lambda: body.t, lambda t, message, **d: messages.append(message), rested.append)
    assert rest.needed()
    rest.rest()
    assert heat.hottest()[1] < HotKnee.hot_c - REST_COOL_K
    assert sum(rested) == pytest.approx(body.t) and body.t > 2 * REST_COOL_K - 2
    assert messages[0] == "resting partway: the l_knee servo is at 66 C; walking on below 50 C"
    assert messages[1].startswith(f"rested {body.t:.0f} s")
    assert not rest.needed()


def test_a_servo_that_does_not_cool_ends_the_walk_with_the_reason() -> None:
    class StuckHot(HotKnee):
        def hottest(self) -> tuple[str, float]:
            return "r_knee", 70.0

    body = MappedBody(_map_with())
    rest = ServoRest(StuckHot(body, 70.0), body.wait, lambda: body.t, lambda *a, **k: None)
    with pytest.raises(NavigationFailed, match="the r_knee servo is still at 70 C after 15 min of rest"):
        rest.rest()
    assert body.t == pytest.approx(MAX_REST_S)


def test_without_a_hot_servo_a_walk_does_not_stop_partway() -> None:
    body = MappedBody(_map_with())
    heat = HotKnee(body, start_c=40.0)
    events: list[str] = []
    states: list[NavigationState] = []
    Navigator(body, lambda: body.t, on_update=states.append, walk_rest=StandingRest(heat, body, events)).go((1.5, 0.0))
    assert events == [] and "resting" not in [s.phase for s in states]
    assert body.stops == 1


def test_a_robot_whose_knee_reaches_the_warning_on_a_walk_rests_partway_and_still_gets_there(make_worker) -> None:
    """The whole robot: a knee heated by fault injection to just under the warning (65 C) reaches it on the walk; the
    robot stops and stands until the knee is at 50 C, without the diagnostics stopping it, then walks on."""
    worker = make_worker(realtime=False, perception=True, max_auto_replans=0)
    events = worker.subscribe()
    start = worker.layout.robot_start
    goal = (start[0], start[1] + 0.8)  # open floor north of the start (seed 0)
    assert worker.wait_for(lambda s: worker.diagnostics() is not None, 60.0)
    knee = next(s for s in worker.diagnostics().statuses if s.name == "servos/l_knee")
    warm_by = 64.0 - float(dict(knee.values)["temperature_c"])
    assert worker.submit(InjectFault(Fault.SERVO_HEAT, "l_knee", warm_by)).accepted
    walk = worker.submit(ExecutePlan({"steps": [{"action": "navigate_to", "target": f"{goal[0]:.2f}, {goal[1]:.2f}"}]}))
    assert walk.accepted
    assert worker.wait_for(
        lambda s: s.navigation is not None and s.navigation.phase == "resting" and s.locomotion.phase == "standing",
        600.0,
    )
    assert worker.wait_for(lambda s: s.plan is not None and s.plan.state in FINISHED, 900.0)
    state = worker.state()
    assert state.plan.state == PlanState.SUCCEEDED, [s.detail for s in state.plan.steps]
    assert not state.estop_latched and not state.fallen
    assert math.dist(state.base_position[:2], goal) < 0.1
    kinds = []
    while (event := events.get(timeout=0.05)) is not None:
        kinds.append((event.kind, event.message))
    resting = [message for kind, message in kinds if kind == "navigation/resting"]
    rested = [message for kind, message in kinds if kind == "navigation/rested"]
    assert len(resting) == 1 and resting[0].startswith("resting partway: the l_knee servo is at 6")
    assert len(rested) == 1 and re.fullmatch(r"rested \d+ s: the hottest servo is at (49|50) C", rested[0])
