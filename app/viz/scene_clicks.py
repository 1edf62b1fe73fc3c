"""A click in a 3D view, from whoever made it (the views' gate says who), as a command like any other: an
operator in control, the e-stop rules, recorded with the session."""

from __future__ import annotations

import threading
from typing import TYPE_CHECKING, Protocol

from app.auth.control import ControlLock, operator_refusal
from app.auth.scene_tokens import SceneGrant
from app.viz.click_goal import Vector, click_plan
from robot.interface import CommandReply, ExecutePlan, Level, Refusal, RobotPort

if TYPE_CHECKING:
    from app.sessions.recorder import SessionRecorder

SOURCE = "3d_view"


class ClickServer(Protocol):
    """What a click needs of the running server (its `Runtime`): who is in control, the robot, the session."""

    control: ControlLock
    worker: RobotPort
    recorder: SessionRecorder


class SceneClicks:
    """Clicks from the 3D views' gates, as commands: checked (role, control), submitted, recorded with the session;
    a refusal makes no plan to show, so it is said in the events (every page lists them)."""

    def __init__(self) -> None:
        self.runtime: ClickServer | None = None  # told once the server's runtime exists (the views start before it)

    def on_click(self, grant: SceneGrant, origin: Vector, direction: Vector) -> None:
        """Called on a gate's event loop (or the mirrors' pipe reader): the work goes to a thread of its own."""
        threading.Thread(target=self.handle, args=(grant, origin, direction), name="scene-click", daemon=True).start()

    def handle(self, grant: SceneGrant, origin: Vector, direction: Vector) -> CommandReply | None:
        made = click_plan(origin, direction)
        rt = self.runtime
        if made is None or rt is None:
            return None
        plan, text = made
        refusal = operator_refusal(rt.control, grant.principal)
        if refusal is not None:
            reply = CommandReply(False, refusal, Refusal.FORBIDDEN)
        else:
            reply = rt.worker.submit(ExecutePlan(plan, text=text))
        rt.recorder.record_command(text, SOURCE, reply)
        if not reply.accepted:
            rt.worker.announce(
                "mirror/click_refused",
                f"3D view click by {grant.user} refused: {reply.message}",
                Level.WARN,
                refusal=reply.refusal.value if reply.refusal else None,
                user=grant.user,
            )
        return reply
