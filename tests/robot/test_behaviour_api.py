"""The behaviour API without a robot: typed parameters with defaults, refusals that name the bad parameter, and
discovery through the `humanoid.behaviours` entry points."""

from __future__ import annotations

import pytest

from robot.behaviours.api import BadParameter, Behaviour, Param
from robot.behaviours.registry import GROUP, discover

NAMES = {"places": ("kitchen counter", "living-room table", "charging dock"), "objects": ("red mug", "green apple")}


class Sample(Behaviour):
    name = "sample"
    description = "a behaviour to check parameters on"
    parameters = (
        Param("laps", int, 2, minimum=0),
        Param("speed", float, 0.5, maximum=1.0),
        Param("loud", bool, False),
        Param("where", str, "start", choices="places", extra=("start",)),
        Param("stops", list, [], choices="places"),
    )
    states = ("only",)

    def step(self, state, robot):  # type: ignore[no-untyped-def]
        return None


def test_defaults_fill_in_and_text_values_are_typed() -> None:
    assert Sample.check_params({}, NAMES) == {"laps": 2, "speed": 0.5, "loud": False, "where": "start", "stops": []}
    checked = Sample.check_params(
        {"laps": "3", "speed": "0.25", "loud": "yes", "where": "the Kitchen Counter", "stops": "dock, table"}, NAMES
    )
    assert checked == {
        "laps": 3,
        "speed": 0.25,
        "loud": True,
        "where": "kitchen counter",
        "stops": ["charging dock", "living-room table"],
    }


@pytest.mark.parametrize(
    ("given", "bad", "why"),
    [
        ({"laps": -1}, "laps", "below the minimum"),
        ({"laps": "two"}, "laps", "whole number"),
        ({"laps": 1.5}, "laps", "whole number"),
        ({"speed": 3}, "speed", "above the maximum"),
        ({"loud": "perhaps"}, "loud", "true or false"),
        ({"where": "garage"}, "where", "unknown place 'garage'"),
        ({"stops": ["kitchen counter", "attic"]}, "stops", "unknown place 'attic'"),
        ({"colour": "red"}, "colour", "no such parameter"),
    ],
)
def test_a_bad_parameter_is_refused_naming_it(given: dict, bad: str, why: str) -> None:
    with pytest.raises(BadParameter) as caught:
        Sample.check_params(given, NAMES)
    assert caught.value.name == bad
    assert bad in str(caught.value) and why in str(caught.value)


def test_a_parameter_of_an_unsupported_type_is_a_programming_error() -> None:
    with pytest.raises(TypeError):
        Param("when", dict, {})


def test_the_built_in_behaviours_are_found_as_entry_points() -> None:
    registry = discover()
    assert {"fetch", "tour", "patrol", "demo"} <= set(registry.behaviours)
    assert not registry.broken
    infos = {info.name: info for info in registry.infos()}
    patrol = infos["patrol"]
    assert patrol.package == "" and patrol.states[0] == "planning"
    laps = next(p for p in patrol.params if p.name == "laps")
    assert (laps.kind, laps.default, laps.minimum) == ("int", 2, 0)
    assert GROUP == "humanoid.behaviours"
