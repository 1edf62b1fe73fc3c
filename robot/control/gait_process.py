"""Gait planners the walking controller talks to: in the caller's thread, or in a child process.

placo holds the GIL for the ~5 ms of each replanning, which would stall a 100 Hz control thread in the same
process; `ProcessGaitPlanner` runs `GaitPlannerCore` in its own Python process (started with `subprocess`, since
the robot worker may itself be a daemon process, which `multiprocessing` forbids to have children). Requests and
segments are pickled over a pair of pipes; the child exits when its request pipe closes. In real time the walk
never waits for a late answer while its current segment lasts (`WalkingController`): a busy machine delays a
replan, it does not stall the control loop.
"""

from __future__ import annotations

import contextlib
import os
import sys
import time
from pathlib import Path

from robot.child_process import PipedChild, child_ends
from robot.control.gait import GaitPlannerCore, GaitSegment, StepCommand

# The walk's plans are part of the control path: the planner answers ahead of ordinary work where the system allows
# it (a niceness, not real-time scheduling: a planner that never returned must not shut the machine out).
GAIT_NICE = -10


# How far ahead an inline plan is sampled (s): the next replan comes 0.1 s on; the rest is slack.
INLINE_HORIZON_S = 0.3


class GaitPlannerError(RuntimeError):
    pass


def _answer(core: GaitPlannerCore, kind: str, command: StepCommand, t: float) -> GaitSegment:
    if kind == "start":
        return core.start(command, t)
    if kind == "replan":
        return core.replan(command, t)
    if kind == "stop":
        return core.stop(t)
    raise GaitPlannerError(f"unknown gait request {kind!r}")


class InlineGaitPlanner:
    """Plans synchronously in the caller's thread (tests, tools); same interface as the process planner.

    Its answer is there when it is due, so a segment is used only until the next replan (0.1 s on): it is sampled
    `INLINE_HORIZON_S` ahead, not the second a late answer from a process needs. Sampling a second, 700 calls into
    placo at every replan, was ~6 % of a headless walking tick."""

    def __init__(self, model_path: Path, dt: float, horizon_s: float = INLINE_HORIZON_S) -> None:
        self.core = GaitPlannerCore(model_path, dt, horizon_s=horizon_s)
        self._answer: GaitSegment | None = None

    def request(self, kind: str, command: StepCommand, t: float) -> None:
        self._answer = _answer(self.core, kind, command, t)

    def result(self, block: bool) -> GaitSegment | None:
        answer, self._answer = self._answer, None
        return answer

    def forget(self) -> None:
        self._answer = None

    def close(self) -> None:
        pass


class ProcessGaitPlanner:
    """Plans in a child process; at most one wanted request is outstanding at a time.

    `result(block=False)` does not wait: a late answer is None until it arrives. An answer the walk no longer wants
    (`forget`, after an e-stop) is dropped when it comes, so forgetting never waits for the child either."""

    def __init__(self, model_path: Path, dt: float) -> None:
        # quiet: placo prints to stdout from C++
        self._child = PipedChild("robot.control.gait_process", str(model_path), str(dt), quiet=True)
        self._wanted = False
        self._unwanted = 0  # forgotten answers still to come, ahead of the wanted one
        self.last_wait_ms = 0.0  # how long the last result() blocked (in real time it never should)
        ready = self._child.receive()
        if ready != "ready":
            raise GaitPlannerError(f"gait planner failed to start: {ready}")

    def request(self, kind: str, command: StepCommand, t: float) -> None:
        if self._wanted:
            raise GaitPlannerError("a gait request is already outstanding")
        self._child.send((kind, command, t))
        self._wanted = True

    def result(self, block: bool) -> GaitSegment | None:
        if not self._wanted:
            return None
        started = time.perf_counter()
        while self._unwanted:
            if not block and not self._child.answered():
                return None
            self._child.receive()
            self._unwanted -= 1
        if not block and not self._child.answered():
            return None
        answer = self._child.receive()
        self.last_wait_ms = (time.perf_counter() - started) * 1e3
        self._wanted = False
        if isinstance(answer, BaseException):
            raise GaitPlannerError(f"gait planning failed: {answer!r}")
        return answer

    def forget(self) -> None:
        if self._wanted:
            self._wanted = False
            self._unwanted += 1

    def close(self) -> None:
        self._child.close()


def _serve(model_path: str, dt: str, request_fd: str, answer_fd: str) -> None:
    requests, answers = child_ends(request_fd, answer_fd)
    try:
        core = GaitPlannerCore(Path(model_path), float(dt))
    except Exception as exc:  # report why, then exit
        answers.send(f"{exc!r}")
        return
    with contextlib.suppress(OSError):  # without the permission, it plans at the ordinary priority
        os.setpriority(os.PRIO_PROCESS, 0, GAIT_NICE)
    answers.send("ready")
    while True:
        try:
            kind, command, t = requests.recv()
        except EOFError:
            return
        try:
            answer: object = _answer(core, kind, command, t)
        except Exception as exc:  # the controller decides what a failed plan means
            answer = exc
        try:
            answers.send(answer)
        except BrokenPipeError:  # the parent closed: nobody wants it
            return


if __name__ == "__main__":
    _serve(*sys.argv[1:5])
