"""Finding behaviours: Python entry points in the group `humanoid.behaviours` (this project's built-ins are
registered in its own pyproject the same way), so a user's package adds one by being installed, without touching
this repository. A broken entry point is reported, never fatal: the others still load."""

from __future__ import annotations

import logging
from dataclasses import dataclass
from importlib.metadata import EntryPoint, entry_points

from robot.behaviours.api import Behaviour
from robot.interface import BehaviourInfo

GROUP = "humanoid.behaviours"
log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Registry:
    """The behaviours found, by name, and what could not be loaded (entry point: reason)."""

    behaviours: dict[str, type[Behaviour]]
    packages: dict[str, str]
    broken: dict[str, str]

    def get(self, name: str) -> type[Behaviour] | None:
        return self.behaviours.get(name.strip().lower())

    def infos(self) -> tuple[BehaviourInfo, ...]:
        return tuple(cls.info(self.packages.get(name, "")) for name, cls in sorted(self.behaviours.items()))


def discover() -> Registry:
    """Every behaviour installed now (read each time: a package installed since is seen by the next robot)."""
    behaviours: dict[str, type[Behaviour]] = {}
    packages: dict[str, str] = {}
    broken: dict[str, str] = {}
    for point in entry_points(group=GROUP):
        try:
            cls = _load(point)
        except Exception as exc:  # a user's package must not stop the robot from starting
            broken[point.name] = f"{type(exc).__name__}: {exc}"
            log.warning("behaviour entry point %s could not be loaded: %s", point.name, broken[point.name])
            continue
        name = cls.name.strip().lower()
        if name in behaviours:
            broken[point.name] = f"a behaviour named {name!r} is already registered"
            continue
        behaviours[name] = cls
        builtin = point.value.startswith("robot.behaviours.")
        packages[name] = "" if builtin or point.dist is None else point.dist.name
    return Registry(behaviours, packages, broken)


def _load(point: EntryPoint) -> type[Behaviour]:
    cls = point.load()
    if not (isinstance(cls, type) and issubclass(cls, Behaviour)):
        raise TypeError(f"{point.value} is not a Behaviour subclass")
    for attribute in ("name", "description", "states"):
        if not getattr(cls, attribute, None):
            raise TypeError(f"{point.value} does not set {attribute}")
    return cls
