"""The example behaviour's own test: its steps against a stand-in robot, and its parameters' checks."""

from __future__ import annotations

import pytest
from wave_hello.behaviour import WaveHello

from robot.behaviours.api import BadParameter


class StandInRobot:
    """Records what the behaviour asks of the robot."""

    def __init__(self) -> None:
        self.did: list[str] = []
        self.progressed = 0.0

    def say(self, text: str) -> str:
        self.did.append(f"say {text}")
        return text

    def gesture(self, name: str, at: str | None = None) -> str:
        self.did.append(name)
        return name

    def feedback(self, line: str) -> None:
        pass

    def progress(self, fraction: float) -> None:
        self.progressed = fraction


def run(behaviour: WaveHello, robot: StandInRobot) -> list[str]:
    states, state = [], WaveHello.states[0]
    while state is not None:
        states.append(state)
        state = behaviour.step(state, robot)  # type: ignore[arg-type]
    return states


def test_it_greets_waves_as_often_as_asked_and_nods() -> None:
    params = WaveHello.check_params({"times": "3", "greeting": "Hi!"}, {})
    robot = StandInRobot()
    states = run(WaveHello(params), robot)
    assert robot.did == ["say Hi!", "wave", "wave", "wave", "nod"]
    assert states == ["greeting", "waving", "waving", "waving", "nodding"]
    assert robot.progressed == 1.0


def test_too_many_waves_are_refused_naming_the_parameter() -> None:
    with pytest.raises(BadParameter) as caught:
        WaveHello.check_params({"times": 9}, {})
    assert caught.value.name == "times"
