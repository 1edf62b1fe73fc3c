"""What a behaviour is: a small typed base class for a long-running mission built on the robot's skills.

A behaviour declares its parameters (typed, with defaults), the states of its state machine, and one method,
`step(state, robot)`, that does the work of a state and returns the next one (None: done). The runner calls it
state after state on the task thread, contained: an exception or a step that overruns `step_timeout_s` ends the
behaviour with the reason, and the robot is left standing with its arm stowed. A step may be run again after a
pause (it is interrupted, then called anew in the same state on resume), so a step should be safe to repeat.

    class Wave(Behaviour):
        name = "wave"
        description = "wave a number of times"
        parameters = (Param("times", int, 2, "how many waves", minimum=1, maximum=5),)
        states = ("waving",)

        def step(self, state: str, robot: BehaviourRobot) -> str | None:
            for _ in range(self.params["times"]):
                robot.gesture("wave")
            return None
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

from robot.behaviours.errors import BadParameter, BehaviourFailed, NoRoomToGesture
from robot.interface import BehaviourInfo, BehaviourParam

if TYPE_CHECKING:
    from robot.behaviours.robot_view import BehaviourRobot

# The parameter types a behaviour may declare, by the name the console and the CLI show.
KINDS: dict[Any, str] = {int: "int", float: "float", str: "str", bool: "bool", list: "list[str]"}
__all__ = ["BadParameter", "Behaviour", "BehaviourFailed", "NoRoomToGesture", "Param"]

DEFAULT_STEP_TIMEOUT_S = 300.0  # simulated seconds one state's step may take before the behaviour is ended


@dataclass(frozen=True)
class Param:
    """One typed parameter: `kind` is int, float, str, bool or list (of text); `choices`: "places" or "objects"
    (the world's names a text value, or each list item, must be one of), and `extra` other values allowed."""

    name: str
    kind: type
    default: Any
    doc: str = ""
    minimum: float | None = None
    maximum: float | None = None
    choices: str | None = None
    extra: tuple[str, ...] = ()  # values allowed besides the choices (e.g. "start" beside the places)

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise TypeError(f"parameter {self.name!r}: kind must be one of int, float, str, bool, list")

    def info(self) -> BehaviourParam:
        default = list(self.default) if isinstance(self.default, tuple) else self.default
        return BehaviourParam(self.name, KINDS[self.kind], default, self.doc, self.minimum, self.maximum, self.choices)

    def coerce(self, value: Any, names: Mapping[str, Sequence[str]]) -> Any:
        """The value as this parameter's type (text from a command line is parsed), checked; else `BadParameter`."""
        value = self._typed(value)
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            if self.minimum is not None and value < self.minimum:
                raise BadParameter(self.name, f"{value!r} is below the minimum {self.minimum:g}")
            if self.maximum is not None and value > self.maximum:
                raise BadParameter(self.name, f"{value!r} is above the maximum {self.maximum:g}")
        if self.choices is not None:
            allowed = (*names.get(self.choices, ()), *self.extra)
            items = value if isinstance(value, list) else [value]
            resolved = []
            for item in items:
                match = _match(item, allowed)
                if match is None:
                    raise BadParameter(self.name, f"unknown {self.choices[:-1]} {item!r} (known: {', '.join(allowed)})")
                resolved.append(match)
            value = resolved if isinstance(value, list) else resolved[0]
        return value

    def _typed(self, value: Any) -> Any:
        kind = self.kind
        if kind is bool:
            if isinstance(value, bool):
                return value
            if isinstance(value, str) and value.strip().lower() in (
                "true",
                "yes",
                "1",
                "on",
                "false",
                "no",
                "0",
                "off",
            ):
                return value.strip().lower() in ("true", "yes", "1", "on")
            raise BadParameter(self.name, f"expected true or false, got {value!r}")
        if kind is int:
            if isinstance(value, bool):
                raise BadParameter(self.name, f"expected a whole number, got {value!r}")
            if isinstance(value, int):
                return value
            if isinstance(value, float) and value.is_integer():
                return int(value)
            if isinstance(value, str):
                try:
                    return int(value.strip())
                except ValueError:
                    pass
            raise BadParameter(self.name, f"expected a whole number, got {value!r}")
        if kind is float:
            if isinstance(value, (int, float)) and not isinstance(value, bool):
                return float(value)
            if isinstance(value, str):
                try:
                    return float(value.strip())
                except ValueError:
                    pass
            raise BadParameter(self.name, f"expected a number, got {value!r}")
        if kind is list:
            if isinstance(value, str):
                value = [v.strip() for v in value.split(",") if v.strip()]
            if isinstance(value, (list, tuple)) and all(isinstance(v, str) for v in value):
                return list(value)
            raise BadParameter(self.name, f"expected a list of names, got {value!r}")
        if not isinstance(value, str):
            raise BadParameter(self.name, f"expected text, got {value!r}")
        return value


def _match(item: str, allowed: Sequence[str]) -> str | None:
    """A world name as typed ("Kitchen Counter", "the sofa") matched to the known one, else None."""
    wanted = " ".join(item.lower().replace("_", " ").split())
    wanted = wanted.removeprefix("the ")
    for name in allowed:
        if name.lower() == wanted:
            return name
    hits = [name for name in allowed if wanted and wanted in name.lower().split()]
    return hits[0] if len(hits) == 1 else None


class Behaviour(ABC):
    """A long-running mission. Subclasses set the class attributes and write `step`; `self.params` holds the
    checked parameters (every declared one, defaults filled in). Instance attributes keep what the behaviour has
    learnt between states (and across a pause)."""

    name: ClassVar[str]
    description: ClassVar[str]
    parameters: ClassVar[tuple[Param, ...]] = ()
    states: ClassVar[tuple[str, ...]]  # the state machine's states; the first is where it starts
    step_timeout_s: ClassVar[float] = DEFAULT_STEP_TIMEOUT_S
    # Whether typed and spoken commands go to this behaviour while it runs (`BehaviourRobot.next_command`) rather
    # than being refused until it ends.
    listens: ClassVar[bool] = False

    def __init__(self, params: Mapping[str, Any]) -> None:
        self.params: dict[str, Any] = dict(params)

    @abstractmethod
    def step(self, state: str, robot: BehaviourRobot) -> str | None:
        """Do the work of `state` with the robot; return the next state, or None when the mission is done. Raise
        `BehaviourFailed` to give up with a reason."""

    @classmethod
    def info(cls, package: str = "") -> BehaviourInfo:
        return BehaviourInfo(cls.name, cls.description, tuple(p.info() for p in cls.parameters), cls.states, package)

    @classmethod
    def check_params(cls, given: Mapping[str, Any], names: Mapping[str, Sequence[str]]) -> dict[str, Any]:
        """Every declared parameter, given or default, typed and checked: `BadParameter` names the first bad one
        (an unknown name too)."""
        declared = {p.name: p for p in cls.parameters}
        for key in given:
            if key not in declared:
                known = ", ".join(declared) or "none"
                raise BadParameter(key, f"{cls.name} has no such parameter (its parameters: {known})")
        checked: dict[str, Any] = {}
        for param in cls.parameters:
            if param.name in given:
                checked[param.name] = param.coerce(given[param.name], names)
            else:
                default = param.default
                checked[param.name] = list(default) if isinstance(default, (list, tuple)) else default
        return checked
