"""Grid paths, lead-ins to an approach heading, and the path follower."""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable

import numpy as np
import pytest

from robot.navigation.costmap import Costmap
from robot.navigation.follower import MAX_FORWARD_M_S, MAX_TURN_RAD_S, SIDE_STEP_M_S, PathFollower
from robot.navigation.grid_planner import astar, inflate, simplify
from robot.navigation.navigator import LEAD_IN_M, LEAD_IN_MAX_DETOUR_M, arrival_point, plan_path


def test_astar_goes_around_a_wall_through_its_gap_without_cutting_corners() -> None:
    blocked = np.zeros((20, 20), dtype=bool)
    blocked[10, :] = True
    blocked[10, 15] = False  # the only gap
    path = astar(blocked, (2, 2), (18, 2))
    assert path is not None and path[0] == (2, 2) and path[-1] == (18, 2)
    assert (10, 15) in path
    for (i, j), (a, b) in itertools.pairwise(path):
        assert max(abs(a - i), abs(b - j)) == 1 and not blocked[a, b]
        if a != i and b != j:
            assert not blocked[a, j] and not blocked[i, b]


def test_astar_says_none_when_the_goal_is_walled_off_or_blocked() -> None:
    blocked = np.zeros((10, 10), dtype=bool)
    blocked[4:7, 4:7] = True
    blocked[5, 5] = False
    assert astar(blocked, (0, 0), (5, 5)) is None  # enclosed
    assert astar(blocked, (0, 0), (4, 4)) is None  # inside an obstacle
    with pytest.raises(ValueError, match="outside the grid"):
        astar(blocked, (0, 0), (10, 3))


def test_inflation_is_a_disc_around_each_blocked_cell() -> None:
    blocked = np.zeros((21, 21), dtype=bool)
    blocked[10, 10] = True
    grown = inflate(blocked, 3.0)
    assert grown[13, 10] and grown[10, 7] and grown[12, 12]
    assert not grown[13, 13]  # the corner of the square is farther than 3 cells
    assert grown.sum() == sum(1 for i in range(-3, 4) for j in range(-3, 4) if i * i + j * j <= 9)


def test_simplify_keeps_only_the_corners_of_a_free_path() -> None:
    path = [(0.0, y * 0.1) for y in range(11)] + [(x * 0.1, 1.0) for x in range(1, 11)]
    assert simplify(path, lambda x, y: x > 0.05 and y < 0.95, 0.02) == [(0.0, 0.0), (0.0, 1.0), (1.0, 1.0)]


def _drive(
    follower: PathFollower, x: float, y: float, yaw: float, blocked_at: Callable[[float, float], bool] | None = None
) -> tuple[bool, list[tuple[float, float, float]]]:
    """A walker that does exactly what the follower says, 0.1 s a step: whether it arrived, and its track."""
    track, dt = [(x, y, yaw)], 0.1
    for _ in range(2000):
        command = follower.update(x, y, yaw, blocked_at)
        if command.arrived:
            return True, track
        assert -SIDE_STEP_M_S <= command.vx <= MAX_FORWARD_M_S + 1e-9 and abs(command.yaw_rate) <= MAX_TURN_RAD_S + 1e-9
        assert abs(command.vy) <= SIDE_STEP_M_S + 1e-9
        x += (command.vx * math.cos(yaw) - command.vy * math.sin(yaw)) * dt
        y += (command.vx * math.sin(yaw) + command.vy * math.cos(yaw)) * dt
        yaw += command.yaw_rate * dt
        track.append((x, y, yaw))
    return False, track


def test_follower_brings_a_unicycle_to_the_goal_within_its_limits() -> None:
    follower = PathFollower([(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)])
    arrived, track = _drive(follower, 0.0, 0.0, math.pi)  # starts facing away: it must turn in place first
    assert arrived and math.dist(track[-1][:2], (1.0, 1.0)) < 0.1


def test_follower_keeps_to_the_path_round_a_corner() -> None:
    """A robot that cut corners would walk into what the path goes round."""
    arrived, track = _drive(PathFollower([(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)]), 0.0, 0.0, 0.0)
    worst = max(min(abs(y) if x <= 1.0 else math.inf, abs(x - 1.0) if y >= 0.0 else math.inf) for x, y, _ in track)
    assert arrived
    assert worst < 0.1  # never more than 10 cm off the path


def test_a_robot_off_its_path_by_a_corner_steers_back_onto_the_path_not_round_the_corner() -> None:
    """World seed 2's patrol: a new path round a chair started where the robot was, but it walked on 10 cm past that
    point before turning; steering at the lookahead round the corner took its shoulder into the chair. Knowing the
    map, the follower steers back onto the path first."""
    chair = (0.1, 0.3, 0.18, 0.4)  # x0, x1, y0, y1: north-east of the path's corner at (-0.11, 0.04)
    path = [(0.0, 0.0), (-0.11, 0.04), (-0.11, 0.8)]
    robot = (0.1, 0.0, 0.0)  # overshot the start, still facing east
    grown = _open_costmap(((chair[0] - 0.2, chair[1] + 0.2, chair[2] - 0.2, chair[3] + 0.2),))

    def closest(track: list[tuple[float, float, float]]) -> float:
        return min(
            math.dist((x, y), (min(max(x, chair[0]), chair[1]), min(max(y, chair[2]), chair[3]))) for x, y, _ in track
        )

    arrived, blind = _drive(PathFollower(path), *robot)
    start = closest([robot])  # 18 cm: the path it was on ran past the chair
    assert arrived and closest(blind) < start - 0.03  # the robot's footprint (16 cm) reaches into the chair
    arrived, seeing = _drive(PathFollower(path), *robot, grown.blocked_at)
    assert arrived and math.dist(seeing[-1][:2], path[-1]) < 0.1
    assert closest(seeing) > start - 0.01


def test_a_robot_beside_its_path_along_a_wall_steps_back_onto_it_without_turning_towards_the_wall() -> None:
    """World seed 18's patrol: 6 cm off its path into a wall's margin, heading along the path, the follower turned
    50 deg in place back towards the path, and the hands (behind the trunk's centre) swung onto the wall. It steps
    sideways instead, keeping its heading along the path."""
    wall_y = 1.5  # a wall north of a path running west along y = 1.2, grown 0.24 m (footprint and berth)
    grown = _open_costmap(((-2.0, 2.0, wall_y - 0.24, 1.5),))
    path = [(1.0, 1.2), (-1.5, 1.2)]
    assert not grown.blocked_at(*path[0]) and grown.blocked_at(0.9, 1.27)
    robot = (0.9, 1.31, math.radians(-174.0))  # beside its path, in the margin, heading west
    arrived, track = _drive(PathFollower(path), *robot, grown.blocked_at)
    assert arrived and math.dist(track[-1][:2], path[-1]) < 0.1
    assert max(abs(math.remainder(yaw - math.pi, math.tau)) for _, _, yaw in track) < math.radians(15.0)
    assert max(y for _, y, _ in track) <= robot[1] + 1e-9  # never nearer the wall


def _open_costmap(blocked_boxes: tuple[tuple[float, float, float, float], ...] = ()) -> Costmap:
    """A 4 x 3 m map centred on the origin, with the given boxes (x0, x1, y0, y1) blocked."""
    resolution = 0.05
    blocked = np.zeros((80, 60), dtype=bool)
    costmap = Costmap(blocked, -2.0, -1.5, resolution)
    for x0, x1, y0, y1 in blocked_boxes:
        for i in range(80):
            for j in range(60):
                cx, cy = costmap.centre(i, j)
                blocked[i, j] |= x0 <= cx <= x1 and y0 <= cy <= y1
    return costmap


def test_a_path_with_a_heading_to_arrive_with_ends_in_a_straight_lead_in_along_it() -> None:
    costmap = _open_costmap()
    goal, facing = (1.0, 0.0), math.pi / 2  # arrive going north, coming from the west
    path = plan_path(costmap, (-1.0, 0.0), goal, facing)
    assert path[-1] == goal
    entry = path[-2]
    assert entry == pytest.approx((goal[0], goal[1] - LEAD_IN_M), abs=1e-9)
    assert _length(path) <= _length(plan_path(costmap, (-1.0, 0.0), goal)) + LEAD_IN_MAX_DETOUR_M


def test_no_lead_in_where_it_does_not_fit_or_the_robot_is_already_there() -> None:
    wall_behind = _open_costmap(((0.5, 1.5, -0.6, -0.1),))  # just south of the goal: no room to come from there
    path = plan_path(wall_behind, (-1.0, 0.0), (1.0, 0.0), math.pi / 2)
    assert path == plan_path(wall_behind, (-1.0, 0.0), (1.0, 0.0))  # the plain shortest path
    near = plan_path(_open_costmap(), (1.0, -0.1), (1.0, 0.0), math.pi / 2)
    assert near == [(1.0, -0.1), (1.0, 0.0)]  # 10 cm away: straight there


def test_the_path_ends_where_the_approach_is_a_straight_walk_ahead() -> None:
    """The staging point moves along its line (across the approach heading) to right behind the approach pose,
    unless that point is taken."""
    staging, pose = (1.29, 0.60), (1.40, 0.71, 0.0)  # the pose 11 cm to the left of the staging point's line
    assert arrival_point(staging, pose, lambda x, y: False) == pytest.approx((1.29, 0.71))
    assert arrival_point(staging, pose, lambda x, y: y > 0.65) == staging
    assert arrival_point(staging, None, lambda x, y: False) == staging


def test_a_follower_on_a_lead_in_path_arrives_lined_up_with_the_approach() -> None:
    """Arriving sideways to the approach costs a slow turn at the surface (6-8 s measured); a path planned with the
    heading to arrive with brings a robot coming from the side in lined up with it."""
    path = plan_path(_open_costmap(), (-1.0, 0.0), (1.0, 0.0), math.pi / 2)
    arrived, track = _drive(PathFollower(path), -1.0, 0.0, 0.0)
    x, y, yaw = track[-1]
    assert arrived and math.dist((x, y), (1.0, 0.0)) < 0.1
    assert abs(math.remainder(yaw - math.pi / 2, math.tau)) < math.radians(10)


def _length(path: list[tuple[float, float]]) -> float:
    return sum(math.dist(a, b) for a, b in itertools.pairwise(path))


def _grown(costmap: Costmap, margin_m: float) -> Costmap:
    return Costmap(inflate(costmap.blocked, margin_m / costmap.resolution), costmap.x0, costmap.y0, costmap.resolution)


def _closest_approach(path: list[tuple[float, float]], box: tuple[float, float, float, float]) -> float:
    x0, x1, y0, y1 = box
    closest = math.inf
    for a, b in itertools.pairwise(path):
        for t in np.linspace(0.0, 1.0, 200):
            x, y = a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])
            closest = min(closest, math.hypot(max(x0 - x, 0.0, x - x1), max(y0 - y, 0.0, y - y1)))
    return closest


def test_a_roomy_map_gives_a_wider_berth_round_a_wall_end_where_there_is_room() -> None:
    """A carrying robot's arm sticks out: round the end of a wall (a doorway) its path keeps the wider berth."""
    wall = (-0.025, 0.025, -1.5, 0.0)  # the south half of the room walled off: round its end at (0, 0)
    world = _open_costmap((wall,))
    usual, roomy = _grown(world, 0.24), _grown(world, 0.30)
    plain = plan_path(usual, (-1.0, -0.5), (1.0, -0.5))
    wide = plan_path(usual, (-1.0, -0.5), (1.0, -0.5), roomy=roomy)
    assert 0.2 < _closest_approach(plain, wall) < 0.25
    assert _closest_approach(wide, wall) > _closest_approach(plain, wall) + 0.04


def test_where_the_wider_berth_does_not_fit_the_usual_one_is_kept() -> None:
    gap = ((-0.025, 0.025, -1.5, -0.3), (-0.025, 0.025, 0.3, 1.5))  # a 0.6 m doorway: room for 0.24, not 0.4
    world = _open_costmap(gap)
    path = plan_path(_grown(world, 0.24), (-1.0, 0.0), (1.0, 0.0), roomy=_grown(world, 0.40))
    assert path[0] == (-1.0, 0.0) and path[-1] == (1.0, 0.0)
    assert min(_closest_approach(path, box) for box in gap) > 0.2


def test_a_wider_berth_that_only_fits_the_long_way_round_is_not_taken() -> None:
    """A doorway with room for the usual berth only, and a wide opening far off: through the doorway."""
    wall = ((-0.025, 0.025, -1.5, -0.3), (-0.025, 0.025, 0.3, 0.6))  # doorway at |y| < 0.3; open above y = 0.6
    world = _open_costmap(wall)
    usual = plan_path(_grown(world, 0.24), (-1.0, -0.5), (1.0, -0.5))
    path = plan_path(_grown(world, 0.24), (-1.0, -0.5), (1.0, -0.5), roomy=_grown(world, 0.40))
    assert max(y for _, y in path) < 0.3  # not round by the far opening
    assert _length(path) == pytest.approx(_length(usual))
