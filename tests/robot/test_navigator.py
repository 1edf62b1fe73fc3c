"""The navigator: the final approach stops on the goal and settles even when stopping moves the robot; backing
away before setting off; getting free of a turn that does not turn."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest

from robot.interface import NavigationState
from robot.navigation.costmap import Costmap
from robot.navigation.follower import MAX_FORWARD_M_S, TURN_IN_PLACE_RAD
from robot.navigation.grid_planner import inflate
from robot.navigation.navigator import (
    CONTROL_PERIOD_S,
    MAX_SETTLE_M,
    OPEN_M_S,
    SETTLE_GROWTH_M,
    SETTLED_M,
    STUCK_S,
    TURN_ROOM_M,
    NavigationFailed,
    Navigator,
    StopDrift,
)


class DriftingBody:
    """Walks exactly as commanded; each stop slides it `drift_m` to its left, as a walking robot's last two steps
    in place do (more when it carries something)."""

    def __init__(self, drift_m: float) -> None:
        self.x = self.y = self.yaw = 0.0
        self.t = 0.0
        self.velocity = (0.0, 0.0, 0.0)
        self.moving = False
        self.drift_m = drift_m
        self.stops = 0

    def pose(self) -> tuple[float, float, float]:
        return (self.x, self.y, self.yaw)

    def costmap(self, inflate_m: float, off_mat_edges: bool = True) -> None:
        return None

    def drive(self, vx: float, vy: float, yaw_rate: float) -> None:
        self.velocity = (vx, vy, yaw_rate)
        if (vx, vy, yaw_rate) != (0.0, 0.0, 0.0):
            self.moving = True
        elif self.moving:
            self.moving = False
            self.stops += 1
            self.x -= math.sin(self.yaw) * self.drift_m
            self.y += math.cos(self.yaw) * self.drift_m

    def halt_here(self) -> None:
        self.drive(0.0, 0.0, 0.0)

    def wait(self, seconds: float) -> None:
        self.t += seconds
        if self.moving:
            vx, vy, w = self.velocity
            c, s = math.cos(self.yaw), math.sin(self.yaw)
            self.x += (c * vx - s * vy) * seconds
            self.y += (s * vx + c * vy) * seconds
            self.yaw += w * seconds

    def walking(self) -> bool:
        return self.moving

    def fallen(self) -> bool:
        return False


def test_a_short_walk_stops_on_the_goal_pose() -> None:
    body = DriftingBody(drift_m=0.0)
    report = Navigator(body, lambda: body.t).step_to((0.3, -0.1, 0.2))
    assert report.final_error_m < 0.02 and report.final_heading_error_deg < 3.0
    assert body.stops == 1 and not body.walking()


def test_when_stopping_drifts_the_robot_it_learns_the_drift_and_stops_that_much_early() -> None:
    body = DriftingBody(drift_m=SETTLED_M + 0.01)
    drift = StopDrift()
    report = Navigator(body, lambda: body.t, stop_drift=drift).step_to((0.3, 0.0, 0.0))
    assert 1 < body.stops <= 3  # the first stop landed outside the tolerance, a later one inside
    assert report.final_error_m < SETTLED_M + SETTLE_GROWTH_M
    assert drift.left > 0.02 and abs(drift.ahead) < 0.01  # it learnt that stopping carries it to its left
    assert body.t < 20.0

    # the next walk, with what the last one learnt, needs fewer stops and comes to rest nearer its goal
    for _ in range(3):
        body.stops = 0
        report = Navigator(body, lambda: body.t, stop_drift=drift).step_to((body.x + 0.3, body.y, 0.0))
    assert body.stops == 1 and report.final_error_m < SETTLED_M


def test_a_stop_the_caller_accepts_ends_the_approach_even_off_the_exact_pose() -> None:
    body = DriftingBody(drift_m=MAX_SETTLE_M - 0.01)  # each stop lands far off: far beyond the first tolerance
    asked: list[tuple[float, float]] = []

    def in_reach() -> bool:  # as the worker judges a work pose: is the object comfortably in the arm's reach?
        asked.append((body.x, body.y))
        return abs(body.y) < 0.08

    report = Navigator(body, lambda: body.t).step_to((0.3, 0.0, 0.0), good_stop=in_reach)
    assert body.stops == 1 and len(asked) == 1
    assert report.final_error_m == pytest.approx(MAX_SETTLE_M - 0.01, abs=0.01)


def test_a_correction_from_standing_near_the_goal_walks_onto_it_instead_of_stopping_where_it_stands() -> None:
    """At a counter's end the reach leaves 3 cm of margin: 2 cm and 3 deg off may be out of reach."""
    body = DriftingBody(drift_m=0.0)
    body.yaw = math.radians(-2.9)
    report = Navigator(body, lambda: body.t).step_to((0.012, 0.015, 0.0))  # 1.9 cm off
    assert body.stops == 1 and report.final_error_m < 0.01 and report.final_heading_error_deg < 1.5


def test_a_robot_that_cannot_stop_near_the_goal_fails_with_the_reason() -> None:
    body = DriftingBody(drift_m=MAX_SETTLE_M + 0.04)
    with pytest.raises(NavigationFailed, match="could not settle on the goal pose"):
        Navigator(body, lambda: body.t).step_to((0.3, 0.0, 0.0))
    assert not body.walking()


class MappedBody(DriftingBody):
    """A `DriftingBody` on an open map, that cannot turn in place while it stands within `stuck_m` of where it
    started (an arm pressed against the end of a wall, which no map shows)."""

    def __init__(self, costmap: Costmap, stuck_m: float = 0.0, mat_edges: np.ndarray | None = None) -> None:
        super().__init__(drift_m=0.0)
        self.map = costmap
        self.stuck_m = stuck_m
        self.mat_edges = mat_edges  # cells where a foot would be on a mat's edge
        self.track: list[tuple[float, float, float]] = []
        self.commands: list[tuple[float, float, float]] = []  # as driven, one per wait

    def costmap(self, inflate_m: float, off_mat_edges: bool = True) -> Costmap:  # type: ignore[override]
        grown = Costmap(
            inflate(self.map.blocked, inflate_m / self.map.resolution), self.map.x0, self.map.y0, self.map.resolution
        )
        return grown.also_blocked(self.mat_edges) if off_mat_edges and self.mat_edges is not None else grown

    def wait(self, seconds: float) -> None:
        vx, vy, w = self.velocity
        if vx == 0.0 and vy == 0.0 and math.hypot(self.x, self.y) < self.stuck_m:
            self.velocity = (0.0, 0.0, 0.0)
        super().wait(seconds)
        self.velocity = (vx, vy, w)
        self.track.append((self.x, self.y, self.yaw))
        self.commands.append(self.velocity)


def _map_with(*cells: tuple[float, float]) -> Costmap:
    costmap = Costmap(np.zeros((80, 60), dtype=bool), -2.0, -1.5, 0.05)
    for x, y in cells:
        costmap.blocked[costmap.cell(x, y)] = True
    return costmap


def test_a_robot_backs_away_first_and_walks_on_into_its_path_without_stopping() -> None:
    """Carrying something held out over a surface, it must not turn there; a stop and a restart cost ~3 s."""
    body = MappedBody(_map_with())
    report = Navigator(body, lambda: body.t).go((-1.0, 0.5), back_away_m=0.1)
    first_turn = next(i for i, (_, _, yaw) in enumerate(body.track) if abs(yaw) > 0.05)
    assert body.track[first_turn - 1][0] == pytest.approx(-0.1, abs=0.015)  # straight back 10 cm, then it turned
    assert all(abs(y) < 1e-9 for _, y, _ in body.track[:first_turn])
    assert body.stops == 1  # only at the end
    assert report.final_error_m < 0.1


def test_a_turn_in_place_that_does_not_turn_steps_clear_of_the_nearest_obstacle_and_goes_on() -> None:
    body = MappedBody(_map_with((0.0, 0.37)), stuck_m=0.03)  # a wall end to its left, beyond TURN_ROOM_M
    report = Navigator(body, lambda: body.t).go((-1.0, -0.5))  # behind it: it must turn round first
    assert min(y for _, y, _ in body.track) < -0.04  # it stepped away from the wall, to its right
    assert report.final_error_m < 0.1
    assert body.t < STUCK_S  # well before it would have given up as stuck


@pytest.mark.parametrize("chair", [(-0.27, 0.0), (-0.2, -0.17)])
def test_a_robot_that_must_turn_in_place_beside_something_steps_clear_of_it_before_turning(chair) -> None:
    """Turning in place, the hands at rest sweep 0.25 m round the trunk: a finger touched a chair 0.27 m behind."""
    body = MappedBody(_map_with(chair))
    report = Navigator(body, lambda: body.t).go((0.0, 1.0))  # to its left: a quarter turn in place first
    turning = [(x, y) for (x, y, _), (vx, vy, w) in zip(body.track, body.commands, strict=True) if vx == vy == 0 != w]
    assert turning and min(math.dist(p, chair) for p in turning) >= TURN_ROOM_M
    assert report.final_error_m < 0.1


def test_a_robot_that_steps_clear_between_two_things_steps_to_where_both_are_furthest() -> None:
    """By the dock on world seed 103 a box stood 0.30 m to one side and the wall 0.33 m to the other: stepping away
    from the box alone took the robot to 0.23 m from the wall, and a finger touched it as the robot turned."""
    wall = [(x / 20.0, -0.33) for x in range(-20, 21)]
    body = MappedBody(_map_with(*wall, (0.05, 0.30)))
    cells = np.array([body.map.centre(i, j) for i, j in np.argwhere(body.map.blocked)])

    def room(x: float, y: float) -> float:
        return float(np.min(np.hypot(cells[:, 0] - x, cells[:, 1] - y)))

    at_start = room(0.0, 0.0)
    report = Navigator(body, lambda: body.t).go((-1.0, 0.0))  # behind it: a half turn in place first
    turning = [(x, y) for (x, y, _), (vx, vy, w) in zip(body.track, body.commands, strict=True) if vx == vy == 0 != w]
    assert turning and min(room(x, y) for x, y in turning) >= at_start
    assert report.final_error_m < 0.1


def test_a_robot_that_must_turn_round_close_to_a_table_steps_back_until_it_has_room_to_turn() -> None:
    """A tour stood 0.12 m from the living-room table's edge: stepping 10 cm back left it 0.25 m away, and a finger
    touched the table as it turned round to leave (world seeds 0, 7 and 9)."""
    edge = [(0.15, y / 20.0) for y in range(-10, 11)]
    body = MappedBody(_map_with(*edge))
    cells = np.array([body.map.centre(i, j) for i, j in np.argwhere(body.map.blocked)])
    report = Navigator(body, lambda: body.t).go((-1.0, 0.0))  # behind it: a half turn in place first
    turning = [(x, y) for (x, y, _), (vx, vy, w) in zip(body.track, body.commands, strict=True) if vx == vy == 0 != w]
    assert turning
    assert min(float(np.min(np.hypot(cells[:, 0] - x, cells[:, 1] - y))) for x, y in turning) >= TURN_ROOM_M
    assert report.final_error_m < 0.1


def test_a_robot_stepping_clear_stops_before_it_nears_something_else() -> None:
    """Between a table ahead and a chair 0.45 m behind there is no room to turn anywhere: it steps back no nearer
    the chair than the table."""
    edge = [(0.15, y / 20.0) for y in range(-10, 11)]
    body = MappedBody(_map_with(*edge, (-0.45, 0.0)))
    cells = np.array([body.map.centre(i, j) for i, j in np.argwhere(body.map.blocked)])
    Navigator(body, lambda: body.t).go((-1.0, 0.6))
    turning = [(x, y) for (x, y, _), (vx, vy, w) in zip(body.track, body.commands, strict=True) if vx == vy == 0 != w]
    x, y = turning[0]
    assert math.dist((x, y), body.map.centre(*body.map.cell(-0.45, 0.0))) > 0.2
    assert float(np.min(np.hypot(cells[:, 0] - x, cells[:, 1] - y))) > 0.2


def test_a_robot_stepping_clear_keeps_its_feet_off_a_mats_edge() -> None:
    """The open floor away from a chair behind it is the dock's pad ahead: the step goes elsewhere (a foot on the
    pad's edge tips the robot over)."""
    chair = _map_with((-0.27, 0.0))
    pad_edge = np.zeros_like(chair.blocked)
    for x in np.arange(0.08, 0.3, 0.05):
        for y in np.arange(-0.1, 0.11, 0.05):
            pad_edge[chair.cell(float(x), float(y))] = True
    body = MappedBody(chair, mat_edges=pad_edge)
    report = Navigator(body, lambda: body.t).go((0.0, 1.0))  # to its left: a quarter turn in place first
    first_turn = next(i for i, (vx, vy, w) in enumerate(body.commands) if vx == vy == 0 != w)
    assert math.hypot(*body.track[first_turn][:2]) > 0.05  # it stepped clear of the chair...
    assert not any(pad_edge[chair.cell(x, y)] for x, y, _ in body.track[: first_turn + 1])  # ...not onto the edge
    assert report.final_error_m < 0.1


def test_a_robot_that_must_turn_about_in_a_corridor_walks_backwards_out_of_it_and_turns_where_there_is_room() -> None:
    """Between a wall and a table 0.5 m apart a replan reversed a patrol: turning about there, it put its fingers on
    the wall whichever way it turned (world seed 18). It walks backwards along its new path until it has room."""
    walls = [(x / 20.0, y) for x in range(-12, 21) for y in (-0.26, 0.26)]  # x from -0.6 to 1.0
    body = MappedBody(_map_with(*walls))
    cells = np.array([body.map.centre(i, j) for i, j in np.argwhere(body.map.blocked)])
    states: list[NavigationState] = []
    report = Navigator(body, lambda: body.t, on_update=states.append).go((-1.6, 0.0))  # behind it: a half turn
    assert report.final_error_m < 0.1
    assert "backing out" in [state.phase for state in states]
    turned = [(x, y) for x, y, yaw in body.track if abs(math.remainder(yaw, math.tau)) > math.radians(20.0)]
    assert turned and min(float(np.min(np.hypot(cells[:, 0] - x, cells[:, 1] - y))) for x, y in turned) >= TURN_ROOM_M
    assert min(float(np.min(np.hypot(cells[:, 0] - x, cells[:, 1] - y))) for x, y, _ in body.track) > 0.2


def _turns_where_it_stands(body: MappedBody) -> bool:
    first_move = next(i for i, command in enumerate(body.commands) if command != (0.0, 0.0, 0.0))
    vx, vy, w = body.commands[first_move]
    return vx == vy == 0.0 and w > 0.0 and math.hypot(*body.track[first_move][:2]) < 1e-9


def test_with_room_to_turn_a_robot_turns_where_it_stands() -> None:
    body = MappedBody(_map_with((-0.45, 0.0)))
    Navigator(body, lambda: body.t).go((0.0, 1.0))
    assert _turns_where_it_stands(body)


def test_on_a_mat_or_carrying_a_robot_turns_where_it_stands_even_beside_something() -> None:
    """A sidestep on the dock's pad put a foot on its edge (tours fell); carrying, it swung the arm held out."""
    chair = _map_with((-0.27, 0.0))
    on_the_pad = np.zeros_like(chair.blocked)
    on_the_pad[chair.cell(0.0, 0.0)] = True
    body = MappedBody(chair, mat_edges=on_the_pad)
    Navigator(body, lambda: body.t).go((0.0, 1.0))
    assert _turns_where_it_stands(body)
    carrying = MappedBody(chair)
    Navigator(carrying, lambda: carrying.t, turn_room_m=0.0).go((0.0, 1.0))
    assert _turns_where_it_stands(carrying)


def test_the_path_end_follows_the_approach_pose_when_what_the_robot_sees_moves_it() -> None:
    """The mug seen 30 cm left of where the counter's default stance assumed: the path bends to the new stance
    instead of leaving a 30 cm sidestep to the slow final approach."""
    body = MappedBody(_map_with())
    seen = {"mug": False}

    def work_pose() -> tuple[float, float, float]:
        seen["mug"] = seen["mug"] or body.x > 0.3  # the camera sees it on the way
        return (1.5, 0.3, 0.0) if seen["mug"] else (1.5, 0.0, 0.0)

    report = Navigator(body, lambda: body.t).go((1.2, 0.0), work_pose)
    at_staging_line = next(y for x, y, _ in body.track if x > 1.15)
    assert at_staging_line > 0.25  # already in line with the new stance when the path ended
    assert report.final_error_m < 0.035 and report.replans == 0  # a moved goal is not a blocked path


class PushedBackBody(MappedBody):
    """Pressed against a box it cannot see on the map: turning in place there, it wobbles about where it started
    (+-14 deg), the box turning it back each time."""

    def wait(self, seconds: float) -> None:
        vx, vy, w = self.velocity
        pressed = vx == 0.0 and vy == 0.0 and w != 0.0 and math.hypot(self.x, self.y) < self.stuck_m
        super().wait(seconds)
        if pressed:
            self.yaw = 0.25 * math.sin(3.0 * self.t)


def test_a_turn_that_only_wobbles_against_something_is_noticed_as_not_turning() -> None:
    body = PushedBackBody(_map_with((0.0, 0.37)), stuck_m=0.03)
    report = Navigator(body, lambda: body.t).go((-1.0, -0.5))  # behind it: it must turn round first
    assert report.final_error_m < 0.1
    assert body.t < STUCK_S  # it stepped clear instead of wobbling until it gave up as stuck


class PinnedBody(MappedBody):
    """Pinned where it stands by something no map shows, turned TURN_IN_PLACE_RAD off its way: any turn only rocks
    it (+-0.1 rad), so the follower's heading error dithers about its threshold and it is told to turn in place and
    to walk on turning by turns, a few times a second. Moving without turning frees it."""

    def wait(self, seconds: float) -> None:
        if self.velocity[2] == 0.0 or math.hypot(self.x, self.y) >= self.stuck_m:
            super().wait(seconds)
            return
        self.t += seconds
        self.yaw = TURN_IN_PLACE_RAD + 0.1 * math.sin(5.0 * self.t)
        self.track.append((self.x, self.y, self.yaw))
        self.commands.append(self.velocity)


def test_a_pinned_robot_told_by_turns_to_turn_in_place_and_to_walk_on_turning_is_noticed_as_not_turning() -> None:
    body = PinnedBody(_map_with((0.0, 0.37)), stuck_m=0.03)
    body.yaw = TURN_IN_PLACE_RAD
    report = Navigator(body, lambda: body.t).go((1.0, 0.0))
    pinned = [vx for (x, y, _), (vx, _, _) in zip(body.track, body.commands, strict=True) if math.hypot(x, y) < 0.03]
    assert 0 < sum(vx == 0.0 for vx in pinned) < len(pinned)  # both kinds of command while pinned
    assert report.final_error_m < 0.1
    assert body.t < STUCK_S  # it stepped clear instead of rocking until it gave up as stuck


class BoxDroppedBody(MappedBody):
    """A box lands across its way at `drop_at_s` (the next map shows it)."""

    def __init__(self, costmap: Costmap, box: tuple[float, float], drop_at_s: float) -> None:
        super().__init__(costmap)
        self.box, self.drop_at_s = box, drop_at_s

    def costmap(self, inflate_m: float, off_mat_edges: bool = True) -> Costmap:  # type: ignore[override]
        if self.t >= self.drop_at_s:
            for dx in (-0.05, 0.0, 0.05):
                for dy in (-0.05, 0.0, 0.05):
                    self.map.blocked[self.map.cell(self.box[0] + dx, self.box[1] + dy)] = True
        return super().costmap(inflate_m, off_mat_edges)


def test_a_box_dropped_in_the_way_is_answered_with_a_new_path_on_the_next_map() -> None:
    """Each new map is checked, not every half second: at 0.2 m/s, 0.4 s is 8 cm nearer the box."""
    body = BoxDroppedBody(_map_with(), box=(1.0, 0.0), drop_at_s=1.25)
    replanned_at: list[float] = []
    navigator = Navigator(body, lambda: body.t, lambda state: replanned_at.append(body.t) if state.replans else None)
    report = navigator.go((1.8, 0.0))
    assert report.replans >= 1 and report.final_error_m < 0.1
    assert replanned_at[0] - body.drop_at_s <= CONTROL_PERIOD_S + 1e-6


def _speeds(body: MappedBody, where: Callable[[float, float], bool]) -> list[float]:
    return [vx for (x, y, _), (vx, _, _) in zip(body.track, body.commands, strict=True) if where(x, y)]


def test_in_the_open_a_robot_with_free_hands_walks_faster_but_not_through_a_doorway_nor_into_its_stop() -> None:
    """At 0.2 m/s its feet swing 7-8 cm off the path: too much beside a doorway's sides; and it stops as it would
    from the usual speed."""
    # a wall at x = 1.6 with a doorway 0.55 m wide (wall cells centred 0.275 m either side of y = 0)
    world = Costmap(np.zeros((120, 60), dtype=bool), -2.0, -1.5, 0.05)
    for y in np.arange(0.26, 1.5, 0.05):
        world.blocked[world.cell(1.6, y)] = world.blocked[world.cell(1.6, -y)] = True
    body = MappedBody(world)
    report = Navigator(body, lambda: body.t).go((3.0, 0.0))
    assert report.final_error_m < 0.1
    assert max(_speeds(body, lambda x, y: x < 0.5)) == pytest.approx(OPEN_M_S)  # the open, far from the wall
    assert max(_speeds(body, lambda x, y: abs(x - 1.6) < 0.2)) <= MAX_FORWARD_M_S + 1e-9  # the doorway
    assert max(_speeds(body, lambda x, y: x > 2.5)) <= MAX_FORWARD_M_S + 1e-9  # its last half metre


def test_a_robot_carrying_something_keeps_to_the_usual_speed_in_the_open() -> None:
    body = MappedBody(_map_with())
    report = Navigator(body, lambda: body.t, open_speed_m_s=MAX_FORWARD_M_S).go((2.0, 0.0))
    assert report.final_error_m < 0.1
    assert max(vx for vx, _, _ in body.commands) == pytest.approx(MAX_FORWARD_M_S)


def test_a_new_path_that_starts_with_a_turn_is_started_afresh_from_where_the_robot_stopped() -> None:
    """A walking robot runs on ~10 cm past where a new path starts (world seed 2's patrol: a box dropped ahead, the
    way round it began with a turn back, and the robot turned by a chair it had walked on towards): a new path it
    cannot take in stride, it stops for, and plans again from where it stands."""
    for box in ((0.6, 0.0), (0.7, 0.0)):
        body = BoxDroppedBody(_map_with(), box=box, drop_at_s=1.0)
        new_paths: list[tuple[tuple[tuple[float, float], ...], tuple[float, float]]] = []

        def published(state: NavigationState, body: BoxDroppedBody = body, seen: list = new_paths) -> None:
            if state.replans:
                seen.append((state.path, (body.x, body.y)))

        report = Navigator(body, lambda body=body: body.t, published).go((1.8, 0.0))
        assert report.replans == 1 and report.final_error_m < 0.1
        assert body.stops == 2  # for the new path, and at the end
        path, stood = new_paths[0]
        assert path[0] == pytest.approx(stood, abs=1e-6)  # planned from where it stood (or stepped clear to)
