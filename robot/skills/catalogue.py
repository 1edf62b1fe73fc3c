"""The skills of one robot, built over its parts, and the plan actions they serve (the executor's capabilities)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from robot.model.world import Place, WorldLayout
from robot.planning.executor import Capability, ExecutionContext, default_capabilities
from robot.planning.world_context import WorldContext
from robot.skills.body import BodyParts
from robot.skills.detect import DetectSkill
from robot.skills.manipulate import ManipulateSkill
from robot.skills.navigate import NavigateSkill
from robot.skills.simple import SimpleActions

# Actions that need the joints: they wait until an arm left finishing in the background has handed them back.
BODY_ACTIONS = ("detect_object", "navigate_to", "pick_object", "place_object", "go_home", "look_around")


@dataclass(frozen=True)
class Skills:
    detect: DetectSkill
    navigate: NavigateSkill
    manipulate: ManipulateSkill
    simple: SimpleActions

    def capabilities(self, arm_settled: Callable[[ExecutionContext], None]) -> dict[str, Capability]:
        """What plan steps can do; `arm_settled` blocks until the arm has finished what it was left doing."""
        capabilities = default_capabilities()
        capabilities["detect_object"] = self.detect.detect_object
        capabilities["navigate_to"] = self.navigate.navigate_to
        capabilities["pick_object"] = self.manipulate.pick_object
        capabilities["place_object"] = self.manipulate.place_object
        capabilities["wait"] = self.simple.wait
        capabilities["stop"] = self.simple.stop
        capabilities["go_home"] = self.simple.go_home
        capabilities["look_around"] = self.simple.look_around
        capabilities["describe_scene"] = self.simple.describe_scene
        for action in BODY_ACTIONS:
            capabilities[action] = _after(arm_settled, capabilities[action])
        return capabilities


def build_skills(
    parts: BodyParts,
    layout: WorldLayout,
    world: Callable[[], WorldContext],
    publish: Callable[..., Any],
) -> Skills:
    manipulate: ManipulateSkill | None = None

    def work_pose(place: Place, ctx: ExecutionContext) -> tuple[tuple[float, float, float], Callable[[], bool] | None]:
        # manipulation knows where to stop for its work (built just below)
        assert manipulate is not None
        return manipulate.work_pose(place, ctx)

    navigate = NavigateSkill(parts, layout, world, publish, work_pose)
    detect = DetectSkill(parts, layout, world, publish)
    manipulate = ManipulateSkill(parts, layout, world, publish, navigate.navigator, navigate.end, detect.looking)
    perception = parts.perception
    simple = SimpleActions(
        navigate=navigate.navigate_to,
        search_body=detect.looking,
        robot_at_rest=lambda: not parts.legs.moving and not parts.arm.active,
        known_objects=lambda: perception.memory.snapshot() if perception is not None else (),
        robot_position=lambda: _position(parts),
        home=layout.robot_start,
        has_camera=perception is not None,
    )
    return Skills(detect, navigate, manipulate, simple)


def _position(parts: BodyParts) -> tuple[float, float]:
    position, _ = parts.localiser.map_trunk()
    return float(position[0]), float(position[1])


def _after(settled: Callable[[ExecutionContext], None], capability: Capability) -> Capability:
    """The capability, run once the arm has finished what it was left doing (it needs the joints)."""

    def run(args: dict[str, str], ctx: ExecutionContext) -> str:
        settled(ctx)
        return capability(args, ctx)

    return run
