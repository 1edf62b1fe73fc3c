"""Gait planners the walking controller talks to: in the caller's thread, or in a child process.

placo holds the GIL for the ~5 ms of each replanning, which would stall a 100 Hz control thread in the same
process; `ProcessGaitPlanner` runs `GaitPlannerCore` in its own Python process (started with `subprocess`, since
the robot worker may itself be a daemon process, which `multiprocessing` forbids to have children). Requests and
segments are pickled over a pair of pipes; the child exits when its request pipe closes.
"""

from __future__ import annotations

import os
import pickle
import sys
import time
from pathlib import Path

from robot.child_process import PipedChild
from robot.control.gait import GaitPlannerCore, GaitSegment, StepCommand


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
    """Plans synchronously in the caller's thread (tests, tools); same interface as the process planner."""

    def __init__(self, model_path: Path, dt: float) -> None:
        self.core = GaitPlannerCore(model_path, dt)
        self._answer: GaitSegment | None = None

    def request(self, kind: str, command: StepCommand, t: float) -> None:
        self._answer = _answer(self.core, kind, command, t)

    def result(self, block: bool) -> GaitSegment | None:
        answer, self._answer = self._answer, None
        return answer

    def close(self) -> None:
        pass


class ProcessGaitPlanner:
    """Plans in a child process; at most one request is outstanding at a time."""

    def __init__(self, model_path: Path, dt: float) -> None:
        # quiet: placo prints to stdout from C++
        self._child = PipedChild("robot.control.gait_process", str(model_path), str(dt), quiet=True)
        self._outstanding = 0
        self.last_wait_ms = 0.0  # how long the last result() blocked (in real time it never should)
        ready = self._child.receive()
        if ready != "ready":
            raise GaitPlannerError(f"gait planner failed to start: {ready}")

    def request(self, kind: str, command: StepCommand, t: float) -> None:
        if self._outstanding:
            raise GaitPlannerError("a gait request is already outstanding")
        self._child.send((kind, command, t))
        self._outstanding = 1

    def result(self, block: bool) -> GaitSegment | None:
        if not self._outstanding:
            return None
        started = time.perf_counter()
        answer = self._child.receive()  # a pipe read; only ever called once the answer is due
        self.last_wait_ms = (time.perf_counter() - started) * 1e3
        self._outstanding = 0
        if isinstance(answer, BaseException):
            raise GaitPlannerError(f"gait planning failed: {answer!r}")
        return answer

    def close(self) -> None:
        self._child.close()


def _serve(model_path: str, dt: str, request_fd: str, answer_fd: str) -> None:
    requests = os.fdopen(int(request_fd), "rb")
    answers = os.fdopen(int(answer_fd), "wb")
    try:
        core = GaitPlannerCore(Path(model_path), float(dt))
    except Exception as exc:  # report why, then exit
        pickle.dump(f"{exc!r}", answers)
        answers.flush()
        return
    pickle.dump("ready", answers)
    answers.flush()
    while True:
        try:
            kind, command, t = pickle.load(requests)
        except EOFError:
            return
        try:
            answer: object = _answer(core, kind, command, t)
        except Exception as exc:  # the controller decides what a failed plan means
            answer = exc
        pickle.dump(answer, answers)
        answers.flush()


if __name__ == "__main__":
    _serve(*sys.argv[1:5])
