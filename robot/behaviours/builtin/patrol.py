"""The patrol: walk a loop of waypoints (default: the open floor near every place, nearest first) for a
number of laps or until stopped, round obstacles (the navigator replans on the lidar map, so one dropped during the
patrol is walked round), and report what changed (a new obstacle, an object moved) with a camera snapshot."""

from __future__ import annotations

from robot.behaviours.api import Behaviour, BehaviourFailed, Param
from robot.behaviours.builtin.changes import ChangeWatch
from robot.behaviours.robot_view import BehaviourRobot
from robot.behaviours.routes import nearest_first

OBSTACLE_LOOK_HEIGHT_M = 0.15


class Patrol(Behaviour):
    name = "patrol"
    description = "walk a loop of waypoints for some laps (0: until stopped), reporting changes"
    parameters = (
        Param("laps", int, 2, "laps to walk (0: until stopped)", minimum=0, maximum=100),
        Param("waypoints", list, [], "places to pass, in order (empty: every place, nearest first)", choices="places"),
    )
    states = ("planning", "walking", "checking")

    def __init__(self, params: dict) -> None:
        super().__init__(params)
        self.route: list[tuple[str, tuple[float, float]]] = []
        self.lap = 0
        self.index = 0
        self.reached = 0
        self.missed: list[str] = []
        self.watch = ChangeWatch()

    def step(self, state: str, robot: BehaviourRobot) -> str | None:
        if state == "planning":
            return self._plan(robot)
        name, (x, y) = self.route[self.index]
        if state == "walking":
            robot.feedback(f"lap {self.lap + 1}: walking to the {name}")
            try:
                robot.go_to(f"{x:.3f}, {y:.3f}")
                self.reached += 1
            except BehaviourFailed as exc:  # a waypoint out of reach now: on to the next, said
                self.missed.append(name)
                robot.feedback(f"could not reach the {name}: {exc}")
            return "checking"
        self._report_changes(robot)
        self.index += 1
        if self.index == len(self.route):
            self.index, self.lap = 0, self.lap + 1
            robot.feedback(f"lap {self.lap} done: {self.reached} waypoints reached, {len(self.missed)} missed")
        laps = self.params["laps"]
        total = laps * len(self.route)
        if total:
            robot.progress((self.lap * len(self.route) + self.index) / total)
        if laps and self.lap >= laps:
            robot.say(f"Patrol done: {laps} laps, {self.reached} waypoints reached.")
            return None
        return "walking"

    def _plan(self, robot: BehaviourRobot) -> str:
        names = list(self.params["waypoints"]) or list(robot.places)
        points = {n: robot.waypoint_near(robot.place(n).staging) for n in names}
        if not self.params["waypoints"]:
            x, y, _ = robot.pose()
            names = nearest_first((x, y), list(points.items()))
        if not names:
            raise BehaviourFailed("no waypoints to patrol")
        self.route = [(n, points[n]) for n in names]
        self.watch.learn(robot.occupancy())  # the map as the patrol starts (the first lap refines it)
        self.watch.moved_objects(robot.known_objects())
        robot.feedback("patrol route: " + " -> ".join(names))
        return "walking"

    def _report_changes(self, robot: BehaviourRobot) -> None:
        if self.lap == 0:
            self.watch.learn(robot.occupancy())
        for obstacle in [] if self.lap == 0 else self.watch.new_obstacles(robot.occupancy()):
            robot.look_at((obstacle.x, obstacle.y, OBSTACLE_LOOK_HEIGHT_M))
            robot.snapshot(
                f"a new obstacle near ({obstacle.x:.2f}, {obstacle.y:.2f})",
                change="obstacle",
                position=[round(obstacle.x, 3), round(obstacle.y, 3)],
            )
        for obj, distance in self.watch.moved_objects(robot.known_objects()):
            robot.look_at(obj.position)
            where = f" on the {obj.place}" if obj.place else ""
            robot.snapshot(
                f"the {obj.name} moved {distance:.2f} m{where}",
                change="moved",
                object=obj.name,
                position=[round(v, 3) for v in obj.position],
            )
