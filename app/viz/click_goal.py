"""Shift+click on the floor of a 3D view sends the robot there: a one-step plan with a `navigate_to` pose goal,
validated and executed like any other plan (refused while the e-stop is latched, shown in the plan panel).

The 3D view only turns shift+clicks on (`enable_clicks`); the click itself reaches the web server through the
views' gate with who made it (`app.viz.scene_gate`), and becomes a command there (`app.viz.scene_clicks`)."""

from __future__ import annotations

from typing import Any

import viser

HINT = "Shift+click on the floor to send the robot there."

Vector = tuple[float, float, float]


def enable_clicks(server: viser.ViserServer) -> None:
    """Browsers send shift+clicks only to a server that listens for them; viser's own callback does nothing
    (the gate takes the click before viser sees it, with who made it)."""
    server.scene.on_click(modifier="shift")(lambda event: None)


def floor_point(origin: Vector, direction: Vector) -> tuple[float, float] | None:
    """Where a view ray meets the floor (z = 0), or None if it never does (looking level or up)."""
    if direction[2] >= -1e-6:
        return None
    t = -origin[2] / direction[2]
    if t < 0:
        return None
    return (origin[0] + t * direction[0], origin[1] + t * direction[1])


def click_plan(origin: Vector, direction: Vector) -> tuple[dict[str, Any], str] | None:
    """The plan a click makes and the command text it is shown and recorded with (None: it missed the floor)."""
    point = floor_point(origin, direction)
    if point is None:
        return None
    target = f"{point[0]:.2f}, {point[1]:.2f}"
    return {
        "steps": [{"action": "navigate_to", "args": {"target": target}}]
    }, f"go to {target} (clicked in the 3D view)"
