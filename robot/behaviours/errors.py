"""What a behaviour (or its parameters) can fail with: the messages are what the operator reads."""

from __future__ import annotations


class BehaviourFailed(Exception):
    """A behaviour gives up: the message is the reason the operator sees."""


class NoRoomToGesture(BehaviourFailed):
    """An arm gesture was not made: something is within the arm's reach wherever the robot could turn. The robot
    has not moved its arm; a show can carry on without that gesture."""


class BadParameter(ValueError):
    """A parameter was refused: `name` is the parameter, the message says why."""

    def __init__(self, name: str, message: str) -> None:
        super().__init__(f"parameter {name!r}: {message}")
        self.name = name
