"""What an in-process robot (the simulation or the bus loop run in the caller's process: tests, headless runs)
adds to its blocking `submit` to be a whole `RobotPort`."""

from __future__ import annotations

import os
from concurrent.futures import Future, ThreadPoolExecutor

from robot.interface import Command, CommandReply

# Planning may take long (an LLM's timeout): a few threads so that an e-stop never waits behind a plan.
_SUBMITTERS = ThreadPoolExecutor(max_workers=4, thread_name_prefix="robot-submit")


class InProcessPort:
    """`submit_async` and `silent_for_s` for a robot whose `submit` blocks the caller."""

    def submit(self, command: Command) -> CommandReply:
        raise NotImplementedError  # the robot's own

    def submit_async(self, command: Command) -> Future[CommandReply]:
        """`submit` on a pool thread: the caller (an event loop) goes on at once."""
        return _SUBMITTERS.submit(self.submit, command)

    @property
    def pid(self) -> int | None:
        """The process the robot runs in: this one."""
        return os.getpid()

    def silent_for_s(self) -> float:
        """Always answering: it runs in this very process."""
        return 0.0
