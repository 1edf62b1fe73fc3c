"""How the web server asks the robot something: awaited on the event loop, never blocking it.

Why: a blocking `submit` on the event loop froze every page and request while the robot process was frozen (an
e-stop pressed then waited up to 90 s, and `/api/health` with it)."""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable

from robot.interface import Command, CommandReply, Refusal, RobotPort, RobotState

# What the robot answers at once (e-stop, teleop, posture, ...): longer than this means it is not answering.
IMMEDIATE_TIMEOUT_S = 5.0
# Planning may take an LLM's timeout, a repair and the rules' fallback.
PLANNING_TIMEOUT_S = 90.0


async def ask(port: RobotPort, command: Command, timeout_s: float = IMMEDIATE_TIMEOUT_S) -> CommandReply:
    """The robot's reply to `command`, or a refusal saying it did not answer in time."""
    try:
        return await asyncio.wait_for(asyncio.wrap_future(port.submit_async(command)), timeout_s)
    except TimeoutError:
        return CommandReply(False, f"the robot did not answer within {timeout_s:.0f} s", Refusal.UNAVAILABLE)


async def shown(port: RobotPort, predicate: Callable[[RobotState], bool], timeout_s: float = 1.0) -> bool:
    """Wait (without blocking the loop) until the robot's state shows what a command changed, so that a client
    reading the state after the reply sees its own change; False when it did not within `timeout_s`."""
    deadline = time.monotonic() + timeout_s
    while not predicate(port.state()):
        if time.monotonic() > deadline:
            return False
        await asyncio.sleep(0.005)
    return True


def tell(port: RobotPort, command: Command) -> None:
    """Send without waiting for the answer (teleop stop, heartbeats): the caller goes on at once."""
    port.submit_async(command)
