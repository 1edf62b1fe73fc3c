"""Fetch: find an object that may be out of view, searching the places in a sensible order (where the world memory
last saw it, then where the world says it belongs, then the other surfaces nearest first), pick it up, bring it to
a named place (default: where the robot started) and say what was done."""

from __future__ import annotations

import math

from robot.behaviours.api import Behaviour, BehaviourFailed, Param
from robot.behaviours.robot_view import BehaviourRobot
from robot.behaviours.routes import nearest_first

START = "start"
# A place lower than this is floor-level (the dock's mat): the object is handed over there, not put down.
MIN_SURFACE_M = 0.05
MAX_PICK_ATTEMPTS = 2


class Fetch(Behaviour):
    name = "fetch"
    description = "find an object (searching the places), pick it up and bring it to a place"
    parameters = (
        Param("object", str, "red mug", "what to fetch", choices="objects"),
        Param("to", str, START, 'a place, or "start" (where the robot started)', choices="places", extra=(START,)),
    )
    states = ("planning", "searching", "picking", "carrying", "delivering")

    def __init__(self, params: dict) -> None:
        super().__init__(params)
        self.candidates: list[str] = []
        self.tried = 0
        self.found_at: str | None = None
        self.pick_attempts = 0

    def step(self, state: str, robot: BehaviourRobot) -> str | None:
        obj = self.params["object"]
        if state == "planning":
            return self._plan(obj, robot)
        if state == "searching":
            return self._search(obj, robot)
        if state == "picking":
            return self._pick(obj, robot)
        destination = self._destination(robot)
        if state == "carrying":
            robot.feedback(f"carrying the {obj} to {_named(destination)}")
            if destination == START:
                x, y, yaw = robot.start_pose
                robot.go_to(f"{x:.3f}, {y:.3f}, {math.degrees(yaw):.0f}")
            else:
                robot.go_to(destination, to_place=destination)
            robot.progress(0.9)
            return "delivering"
        if not robot.still_holding():  # it slipped out on the way: say so, not "here it is" (world 204, 2 of 3)
            raise BehaviourFailed(
                f"the {obj} is no longer in my hand: it slipped out on the way to {_named(destination)}"
            )
        if destination != START and robot.place(destination).surface_height >= MIN_SURFACE_M:
            robot.put_down(destination)
            done = f"I put the {obj} on the {destination}."
        else:
            done = f"I brought the {obj} to {_named(destination)}: here it is."
        where = f" I found it on the {self.found_at}." if self.found_at else ""
        robot.say(done + where)
        robot.feedback(done + where)
        return None

    def _destination(self, robot: BehaviourRobot) -> str:
        to = self.params["to"]
        if to != START and to not in robot.places:
            raise BehaviourFailed(f"unknown place {to!r} to bring the object to")
        return to

    def _plan(self, obj: str, robot: BehaviourRobot) -> str:
        """Where to look, most likely first: where it was last seen, where it belongs, then the rest nearest first."""
        self._destination(robot)  # an unknown destination fails now, not after the walk
        if robot.holding == obj:
            self.found_at = None
            return "carrying"
        first: list[str] = []
        known = robot.remembered(obj)
        if known is not None and known.place in robot.places:
            first.append(known.place)
        believed = robot.believed_place(obj)
        if believed in robot.places and believed not in first:
            first.append(believed)
        x, y, _ = robot.pose()
        rest = [(p, robot.place(p).staging) for p in robot.places if p not in first and robot.place(p).surface]
        self.candidates = first + nearest_first((x, y), rest)
        robot.feedback(f"looking for the {obj}: " + ", then ".join(f"the {p}" for p in self.candidates))
        return "searching"

    def _pick(self, obj: str, robot: BehaviourRobot) -> str:
        """Pick it up; a grasp that fails is tried again once, after looking for the object anew (it may have been
        nudged)."""
        robot.feedback(f"picking up the {obj}")
        self.pick_attempts += 1
        try:
            robot.go_to(self.found_at or self.candidates[self.tried], to_pick=obj)
            robot.pick(obj)
        except BehaviourFailed as exc:
            if self.pick_attempts >= MAX_PICK_ATTEMPTS or robot.holding is not None:
                raise
            robot.feedback(f"the pick failed ({exc}): looking again")
            return "searching"
        robot.progress(0.6)
        return "carrying"

    def _search(self, obj: str, robot: BehaviourRobot) -> str:
        while self.tried < len(self.candidates):
            place = self.candidates[self.tried]
            robot.feedback(f"searching the {place}")
            robot.go_to(place, to_pick=obj)
            try:
                robot.detect(obj)
            except BehaviourFailed as exc:
                robot.feedback(f"not at the {place}: {exc}")
                self.tried += 1
                robot.progress(0.4 * self.tried / len(self.candidates))
                continue
            self.found_at = place
            robot.feedback(f"found the {obj} at the {place}")
            robot.progress(0.4)
            return "picking"
        raise BehaviourFailed(f"the {obj} is not at any place: looked at " + ", ".join(self.candidates))


def _named(destination: str) -> str:
    return "where I started" if destination == START else f"the {destination}"
