"""Plan actions built from the robot's other abilities: wait, stop, go home, look around, describe the scene.

Each is real: waiting and stopping hold the robot still in simulated time, going home walks the navigator to the
start pose, looking around sweeps the camera over a full turn (the world memory takes in what it sees), and the
description is read from that memory at run time, not made up when the plan was.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from robot.interface import KnownObject
from robot.navigation.goal import PoseGoal
from robot.perception.search import SearchBody, look_around
from robot.planning.executor import ExecutionContext, StepFailed


@dataclass
class SimpleActions:
    """The capabilities, over what they need from the robot (given as callables, so tests can stand them in)."""

    navigate: Callable[[dict[str, str], ExecutionContext], str]
    search_body: Callable[[ExecutionContext], SearchBody]
    robot_at_rest: Callable[[], bool]
    known_objects: Callable[[], tuple[KnownObject, ...]]
    robot_position: Callable[[], tuple[float, float]]
    home: tuple[float, float, float]  # x, y, yaw of the start pose
    has_camera: bool = True

    def wait(self, args: dict[str, str], ctx: ExecutionContext) -> str:
        seconds = float(args["seconds"])
        ctx.wait_sim(seconds)
        return f"waited {seconds:g} s"

    def stop(self, args: dict[str, str], ctx: ExecutionContext) -> str:
        """The plan this step is in has already replaced whatever ran; wait until the legs and arm are still."""
        waited = 0.0
        while not self.robot_at_rest():
            ctx.wait_sim(0.05)
            waited += 0.05
            if waited > 10.0:
                raise StepFailed("the robot did not come to rest within 10 s")
        return "stopped: standing still" + (f" after {waited:.1f} s" if waited else "")

    def go_home(self, args: dict[str, str], ctx: ExecutionContext) -> str:
        x, y, yaw = self.home
        return "home: " + self.navigate({"target": PoseGoal(x, y, math.degrees(yaw)).text()}, ctx)

    def look_around(self, args: dict[str, str], ctx: ExecutionContext) -> str:
        if not self.has_camera:
            raise StepFailed("looking around needs the camera, and perception is off in this worker")
        result = look_around(self.search_body(ctx), ctx.check_cancelled)
        if not result.seen:
            return f"looked in {result.views} directions over a full turn: saw none of the known objects"
        seen = ", ".join(f"{label} ({d.distance_m:.1f} m)" for label, d in sorted(result.seen.items()))
        return f"looked in {result.views} directions over a full turn: saw {seen}"

    def describe_scene(self, args: dict[str, str], ctx: ExecutionContext) -> str:
        sentence = describe(self.known_objects(), self.robot_position())
        ctx.say(sentence)
        return f'said "{sentence}"'


def describe(known: tuple[KnownObject, ...], position: tuple[float, float]) -> str:
    """One sentence on what the world memory holds, nearest first: what an operator asking "what do you see"
    wants to hear."""
    if not known:
        return "I have not seen any of the objects I know."

    def distance(k: KnownObject) -> float:
        return math.hypot(k.position[0] - position[0], k.position[1] - position[1])

    parts = []
    for k in sorted(known, key=distance):
        where = f" on the {k.place}" if k.place and k.place != "floor" else (" on the floor" if k.place else "")
        parts.append(f"the {k.name}{where}, {distance(k):.1f} metres away")
    if len(parts) == 1:
        return f"I see {parts[0]}."
    return f"I see {', '.join(parts[:-1])} and {parts[-1]}."
