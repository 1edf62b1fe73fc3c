"""A walk that stops partway to let a hot servo cool, before the diagnostics stop the robot (the navigator's
`WalkRest`).

A walk stops when a servo reaches the diagnostics' warning (`ServoHeat.hot_c`, 65 C; at 75 C they stop the robot),
and the robot stands until the hottest servo is REST_COOL_K below it (50 C). Walking warms a knee about 0.3 K a
second in simulation; standing, it cools from 65 C to 50 C in about 4.5 min. A behaviour rests before a walk that
starts hot (`BehaviourRobot.rest_if_hot`), but a walk can run long: a patrol's walk round a table through 0.5 m
corridors, replanning and stepping clear, heated a knee from 50 C to 75 C, and the diagnostics stopped it (world
seed 18).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from robot.navigation.navigator import NavigationFailed
from robot.skills.body import ServoHeat

REST_COOL_K = 15.0
REST_CHECK_S = 2.0
MAX_REST_S = 900.0


class StillHot(Exception):
    """A servo did not cool below the mark in MAX_REST_S of rest (a fan, a load or a fault to look at)."""

    def __init__(self, joint: str, temperature_c: float) -> None:
        super().__init__(f"the {joint} servo is still at {temperature_c:.0f} C after {MAX_REST_S / 60:.0f} min of rest")
        self.joint = joint
        self.temperature_c = temperature_c


def stand_until_cool(
    heat: ServoHeat, cool_c: float, wait_sim: Callable[[float], None], rested: Callable[[float], None]
) -> tuple[str, float]:
    """Wait standing, REST_CHECK_S at a time (each handed to `rested`), until the hottest servo is below `cool_c`;
    the hottest joint and its temperature then. `StillHot` after MAX_REST_S. Shared by the rest before a
    behaviour's walk and the rest partway through one."""
    joint, temperature = heat.hottest()
    waited = 0.0
    while temperature >= cool_c:
        if waited >= MAX_REST_S:
            raise StillHot(joint, temperature)
        wait_sim(REST_CHECK_S)
        waited += REST_CHECK_S
        rested(REST_CHECK_S)
        joint, temperature = heat.hottest()
    return joint, temperature


class ServoRest:
    """The navigator's `WalkRest` for hot servos. Each rest is published (`navigation/resting`, `navigation/rested`),
    and its simulated seconds handed to `rested` as they pass (a behaviour's step timeout does not count them)."""

    def __init__(
        self,
        heat: ServoHeat,
        wait_sim: Callable[[float], None],
        now: Callable[[], float],
        publish: Callable[..., Any],
        rested: Callable[[float], None] = lambda seconds: None,
    ) -> None:
        self._heat = heat
        self._wait_sim = wait_sim
        self._now = now
        self._publish = publish
        self._rested = rested

    def needed(self) -> bool:
        return self._heat.hottest()[1] >= self._heat.hot_c

    def rest(self) -> None:
        joint, temperature = self._heat.hottest()
        cool_c = self._heat.hot_c - REST_COOL_K
        self._publish(
            "navigation/resting",
            f"resting partway: the {joint} servo is at {temperature:.0f} C; walking on below {cool_c:.0f} C",
            joint=joint,
            temperature_c=temperature,
        )
        started = self._now()
        try:
            joint, temperature = stand_until_cool(self._heat, cool_c, self._wait_sim, self._rested)
        except StillHot as hot:
            raise NavigationFailed(str(hot)) from hot
        self._publish(
            "navigation/rested",
            f"rested {self._now() - started:.0f} s: the hottest servo is at {temperature:.0f} C",
            rested_s=self._now() - started,
        )
