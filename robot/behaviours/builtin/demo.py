"""The interactive demo: greets, says what the robot can do, performs gestures with its arm and head (wave, nod,
shake the head, point at a named object it has seen), and between them takes the commands typed or spoken to it
(while it runs, commands go to the demo: "what can you do", "wave", "nod", "point at the red mug", or any command
the planner reads, such as "look around" or "go to the dock")."""

from __future__ import annotations

import re

from robot.behaviours.api import Behaviour, BehaviourFailed, NoRoomToGesture, Param
from robot.behaviours.robot_view import BehaviourRobot

GESTURE_WORDS = {"wave": "wave", "nod": "nod", "shake": "shake_head", "shake your head": "shake_head"}
ABILITIES = (
    "walk to any place I know",
    "look for objects and pick them up",
    "carry things from place to place",
    "patrol, give tours and fetch things",
    "wave, nod, shake my head and point",
)


class Demo(Behaviour):
    name = "demo"
    description = "an interactive show: greets, says what it can do, gestures, takes commands between them"
    parameters = (
        Param(
            "point_at", str, "", "an object to point at (empty: the nearest one seen)", choices="objects", extra=("",)
        ),
        Param("listen_s", float, 8.0, "how long to wait for commands between gestures (s)", minimum=0.0, maximum=120.0),
        Param("rounds", int, 1, "times through the show", minimum=1, maximum=10),
    )
    states = ("greeting", "explaining", "gesturing", "listening", "farewell")
    listens = True

    def __init__(self, params: dict) -> None:
        super().__init__(params)
        self.gestures = ["nod", "shake_head", "point", "wave"]  # it greeted with a wave: that comes last
        self.done: list[str] = []
        self.round = 0

    def step(self, state: str, robot: BehaviourRobot) -> str | None:
        if state == "greeting":
            robot.say("Hello! I am a small humanoid robot. Welcome to my demo.")
            if (done := _gesture_if_room(robot, "wave")) is not None:
                robot.feedback("greeted with a wave" + _detail(done))
            return "explaining"
        if state == "explaining":
            robot.say(what_i_can_do())
            robot.feedback("said what it can do")
            return "gesturing"
        if state == "gesturing":
            return self._gesture(robot)
        if state == "listening":
            return self._listen(robot)
        robot.say("That is the end of my demo. Thank you for watching!")
        _gesture_if_room(robot, "wave")
        return None

    def _gesture(self, robot: BehaviourRobot) -> str:
        gesture = self.gestures[len(self.done) % len(self.gestures)]
        if gesture == "point":
            target = self._point_target(robot)
            if target is None:
                robot.feedback("nothing seen to point at")
            else:
                robot.say(f"That is the {target}.")
                if (done := _gesture_if_room(robot, "point", target)) is not None:
                    robot.feedback(f"pointed at the {target}" + _detail(done))
        elif (done := _gesture_if_room(robot, gesture)) is not None:
            robot.feedback(f"gesture: {gesture.replace('_', ' ')}" + _detail(done))
        self.done.append(gesture)
        total = len(self.gestures) * self.params["rounds"]
        robot.progress(len(self.done) / total)
        return "listening"

    def _listen(self, robot: BehaviourRobot) -> str:
        text = robot.next_command(self.params["listen_s"])
        if text is not None:
            self._serve(text, robot)
            return "listening"  # more may come
        total = len(self.gestures) * self.params["rounds"]
        return "gesturing" if len(self.done) < total else "farewell"

    def _serve(self, text: str, robot: BehaviourRobot) -> None:
        said = text.lower()
        robot.feedback(f"heard: {text}")
        if re.search(r"what (?:can|do) you do|what are you able", said):
            robot.say(what_i_can_do())
            return
        pointing = re.search(r"point (?:at|to) (?:the )?(.+)", said)
        if pointing:
            target = next((o for o in robot.objects if o in pointing.group(1)), None)
            if target is None:
                robot.say("I do not know that object.")
                return
            _gesture_if_room(robot, "point", target)
            return
        gesture = next((g for word, g in GESTURE_WORDS.items() if re.search(rf"\b{word}\b", said)), None)
        if gesture is not None:
            _gesture_if_room(robot, gesture)
            return
        try:
            robot.feedback("did: " + robot.run_command(text))
        except BehaviourFailed as exc:  # a command that fails does not end the show
            robot.say("Sorry, I could not do that.")
            robot.feedback(f"could not do {text!r}: {exc}")

    def _point_target(self, robot: BehaviourRobot) -> str | None:
        wanted = self.params["point_at"]
        if wanted and robot.remembered(wanted) is None:
            robot.look_around()
        if wanted:
            return wanted if robot.remembered(wanted) is not None else None
        known = robot.known_objects()
        if not known:
            robot.look_around()
            known = robot.known_objects()
        if not known:
            return None
        x, y, _ = robot.pose()
        return min(known, key=lambda k: (k.position[0] - x) ** 2 + (k.position[1] - y) ** 2).name


def _gesture_if_room(robot: BehaviourRobot, name: str, at: str | None = None) -> str | None:
    """A gesture (what was done), or None and a line saying why it was left out when the arm has no room: the
    show goes on."""
    try:
        return robot.gesture(name, at=at)
    except NoRoomToGesture as exc:
        robot.say("I will not move my arm here: something is too close.")
        robot.feedback(f"left out {name.replace('_', ' ')}: {exc}")
        return None


def _detail(done: str) -> str:
    """The part of a gesture's report in brackets (" (turned 45 deg first, ...)"), if any."""
    return done[done.index(" (") :] if " (" in done else ""


def what_i_can_do() -> str:
    return "I can " + ", ".join(ABILITIES[:-1]) + f", and {ABILITIES[-1]}."
