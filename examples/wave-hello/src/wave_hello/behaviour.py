"""Wave hello: greet, wave a number of times, nod. A behaviour as a user writes one: declared parameters and
states, and a `step` that does one state's work with the robot and says which state comes next."""

from __future__ import annotations

from robot.behaviours.api import Behaviour, Param
from robot.behaviours.robot_view import BehaviourRobot


class WaveHello(Behaviour):
    name = "wave_hello"
    description = "greet, wave a number of times, then nod"
    parameters = (
        Param("times", int, 2, "how many waves", minimum=1, maximum=5),
        Param("greeting", str, "Hello there!", "what to say first"),
    )
    states = ("greeting", "waving", "nodding")
    step_timeout_s = 120.0  # simulated seconds any one state may take

    def __init__(self, params: dict) -> None:
        super().__init__(params)
        self.waved = 0  # kept across a pause: a resumed wave goes on counting

    def step(self, state: str, robot: BehaviourRobot) -> str | None:
        if state == "greeting":
            robot.say(self.params["greeting"])
            robot.feedback(f"said {self.params['greeting']!r}")
            return "waving"
        if state == "waving":
            robot.gesture("wave")
            self.waved += 1
            robot.progress(self.waved / (self.params["times"] + 1))
            robot.feedback(f"wave {self.waved} of {self.params['times']}")
            return "waving" if self.waved < self.params["times"] else "nodding"
        robot.gesture("nod")
        robot.progress(1.0)
        return None
