"""The MuJoCo scene a stored session was recorded in, for replaying and exporting it."""

from __future__ import annotations

import logging

import mujoco

from robot.model.scene import scene_xml
from robot.model.world import generate_world

log = logging.getLogger(__name__)


def session_scene(scene_mjcf: str | None, seed: int) -> tuple[mujoco.MjModel, str]:
    """The session's own scene (its MJCF, recorded when it started) compiled, and its MJCF; for sessions from
    before that was recorded, or whose mesh files are not on this machine, the world of its seed built again."""
    if scene_mjcf:
        try:
            return mujoco.MjModel.from_xml_string(scene_mjcf), scene_mjcf
        except ValueError as exc:  # e.g. an import from another machine: its mesh paths are not here
            log.warning("the session's scene does not load here (%s): building the world of seed %d", exc, seed)
    xml = scene_xml(generate_world(seed))
    return mujoco.MjModel.from_xml_string(xml), xml
