"""The guided tour: visit places (default: all, nearest first), and at each stop face it and say a sentence about
it from what the robot knows (the place, its room) and sees there now (the camera's detections, the world
memory)."""

from __future__ import annotations

from robot.behaviours.api import Behaviour, BehaviourFailed, Param
from robot.behaviours.robot_view import BehaviourRobot
from robot.behaviours.routes import nearest_first


class Tour(Behaviour):
    name = "tour"
    description = "visit places (default: all), face each and say what is there"
    parameters = (Param("places", list, [], "places to visit, in order (empty: all, nearest first)", choices="places"),)
    states = ("planning", "walking", "presenting")

    def __init__(self, params: dict) -> None:
        super().__init__(params)
        self.route: list[str] = []
        self.stop = 0
        self.said: list[str] = []
        self.skipped: list[tuple[str, str]] = []  # places it could not reach, and why

    def step(self, state: str, robot: BehaviourRobot) -> str | None:
        if state == "planning":
            return self._plan(robot)
        place = self.route[self.stop]
        if state == "walking":
            robot.feedback(f"walking to the {place} (stop {self.stop + 1} of {len(self.route)})")
            try:
                robot.go_to(place)
            except BehaviourFailed as exc:  # out of reach now (something in the way): on to the next stop, said
                robot.feedback(f"could not reach the {place}: {exc}")
                self.skipped.append((place, str(exc)))
                self.stop += 1
                return "walking" if self.stop < len(self.route) else self._end(robot)
            return "presenting"
        sentence = self._present(place, robot)
        robot.say(sentence)
        robot.feedback(f"at the {place}: {sentence}")
        self.said.append(sentence)
        self.stop += 1
        robot.progress(self.stop / len(self.route))
        return "walking" if self.stop < len(self.route) else self._end(robot)

    def _end(self, robot: BehaviourRobot) -> None:
        if len(self.skipped) == len(self.route):
            reasons = "; ".join(f"the {place}: {why}" for place, why in self.skipped)
            raise BehaviourFailed(f"could not reach any place of the tour ({reasons})")
        if self.skipped:
            robot.say("I could not get to " + " or ".join(f"the {p}" for p, _ in self.skipped) + " this time.")
        return None

    def _plan(self, robot: BehaviourRobot) -> str:
        chosen = list(self.params["places"]) or list(robot.places)
        if not self.params["places"]:
            x, y, _ = robot.pose()
            chosen = nearest_first((x, y), [(p, robot.place(p).staging) for p in chosen])
        self.route = chosen
        robot.feedback("the tour: " + ", then ".join(f"the {p}" for p in chosen))
        return "walking"

    def _present(self, place: str, robot: BehaviourRobot) -> str:
        """Face the place, look, and put what is known and seen into one sentence."""
        where = robot.place(place)
        if where.surface is not None:
            robot.face((where.surface.x, where.surface.y))
            robot.look_at((where.surface.x, where.surface.y, where.surface.height))
        surface = where.surface
        seen = {d.label for d in robot.seen_now() if surface is not None and surface.contains(*d.position[:2], 0.05)}
        remembered = {k.name for k in robot.known_objects() if k.place == place}
        here = sorted(seen | remembered)
        opening = f"This is the {place}, in the {where.room}."
        if not here:
            return f"{opening} I see nothing I know on it right now."
        listed = (
            f"the {here[0]}" if len(here) == 1 else ", ".join(f"the {n}" for n in here[:-1]) + f" and the {here[-1]}"
        )
        return f"{opening} Here I can see {listed}."
