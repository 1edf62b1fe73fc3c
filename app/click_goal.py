"""Shift+click on the floor of the 3D view sends the robot there: a one-step plan with a `navigate_to` pose goal,
validated and executed like any other plan (refused while the e-stop is latched, shown in the plan panel)."""

from __future__ import annotations

from typing import Any

import viser

from robot.interface import CommandReply, ExecutePlan, RobotPort

HINT = "Shift+click on the floor to send the robot there."


Vector = tuple[float, float, float]


def floor_point(origin: Vector, direction: Vector) -> tuple[float, float] | None:
    """Where a view ray meets the floor (z = 0), or None if it never does (looking level or up)."""
    if direction[2] >= -1e-6:
        return None
    t = -origin[2] / direction[2]
    if t < 0:
        return None
    return (origin[0] + t * direction[0], origin[1] + t * direction[1])


class ClickToGo:
    def __init__(self, server: viser.ViserServer, port: RobotPort) -> None:
        self._port = port
        self.last_reply: CommandReply | None = None
        server.scene.on_click(modifier="shift")(self.on_click)

    def on_click(self, event: Any) -> CommandReply | None:
        point = floor_point(tuple(event.ray_origin), tuple(event.ray_direction))
        if point is None:
            return None
        target = f"{point[0]:.2f}, {point[1]:.2f}"
        plan = {"steps": [{"action": "navigate_to", "args": {"target": target}}]}
        self.last_reply = self._port.submit(ExecutePlan(plan, text=f"go to {target} (clicked in the 3D view)"))
        return self.last_reply
