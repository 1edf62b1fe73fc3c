"""Where the sensor suite runs: in a child process (and, inside it, in the calling thread).

Rendering holds the interpreter lock for its ~10 ms (measured: a thread rendering in a loop delayed a 100 Hz
loop in the same process by up to 0.7 s), so the suite runs in its own process, like the gait
planner (started with `subprocess`, since the robot worker may itself be a daemon process). The child builds its
own copy of the scene from the layout and keeps the occupancy map; each request is one sensing instant.
"""

from __future__ import annotations

import contextlib
import os
import sys
from typing import Protocol

from robot.child_process import PipedChild, child_ends
from robot.model.world import WorldLayout
from robot.perception.occupancy import OccupancyGrid
from robot.perception.suite import SensorOutput, SensorSnapshot, SensorSuite


class SensorError(RuntimeError):
    pass


class SensorRunner(Protocol):
    def process(self, snapshot: SensorSnapshot) -> SensorOutput: ...

    def clear_map(self) -> OccupancyGrid: ...

    def close(self) -> None: ...


class InlineSensors:
    """The suite in the calling thread (the sensor process's). Create and use it on one thread (EGL)."""

    def __init__(self, layout: WorldLayout) -> None:
        self.suite = SensorSuite(layout)

    def process(self, snapshot: SensorSnapshot) -> SensorOutput:
        return self.suite.process(snapshot)

    def clear_map(self) -> OccupancyGrid:
        self.suite.mapper.clear()
        self.suite.matcher.reset()
        return self.suite.map()

    def close(self) -> None:
        self.suite.close()


class ProcessSensors:
    """The suite in a child process; one request at a time, answered in order."""

    def __init__(self, layout: WorldLayout) -> None:
        self._child = PipedChild("robot.perception.sensor_process")
        self._call(("start", layout))

    def _call(self, request: tuple[object, ...]) -> object:
        try:
            self._child.send(request)
            answer = self._child.receive()
        except (OSError, EOFError) as exc:
            raise SensorError(f"the sensor process is gone (exit code {self._child.process.poll()})") from exc
        if isinstance(answer, BaseException):
            raise SensorError(f"sensing failed: {answer!r}") from answer
        return answer

    @property
    def pid(self) -> int:
        return self._child.process.pid

    def process(self, snapshot: SensorSnapshot) -> SensorOutput:
        answer = self._call(("process", snapshot))
        assert isinstance(answer, SensorOutput)
        return answer

    def clear_map(self) -> OccupancyGrid:
        answer = self._call(("clear_map",))
        assert isinstance(answer, OccupancyGrid)
        return answer

    def close(self) -> None:
        self._child.close()


SENSOR_NICE = 10


def _lower_priority() -> None:
    """Sensing must never compete with the control loop, nor with the e-stop's way through the web server and the
    operator's browser on the same two cores: this process may have inherited the worker's real-time scheduling;
    it runs as a batch job instead (SCHED_BATCH: it never preempts a task that wakes, and a woken task preempts it
    sooner) at nice 10. It still gets the CPU the others leave (the suite needs ~30 % of a core at 10 Hz)."""
    with contextlib.suppress(OSError, AttributeError, PermissionError):
        os.sched_setscheduler(0, os.SCHED_BATCH, os.sched_param(0))
    with contextlib.suppress(OSError):
        os.nice(SENSOR_NICE - os.nice(0))


def _serve(request_fd: str, answer_fd: str) -> None:
    _lower_priority()
    requests, answers = child_ends(request_fd, answer_fd)
    sensors: InlineSensors | None = None
    while True:
        try:
            request = requests.recv()
        except EOFError:
            break
        try:
            if request[0] == "start":
                sensors = InlineSensors(request[1])
                answer: object = "ready"
            elif sensors is None:
                answer = SensorError("the sensor suite was not started")
            elif request[0] == "process":
                answer = sensors.process(request[1])
            elif request[0] == "clear_map":
                answer = sensors.clear_map()
            else:
                answer = SensorError(f"unknown request {request[0]!r}")
        except Exception as exc:  # the worker decides what a failed frame means
            answer = exc
        try:
            answers.send(answer)
        except BrokenPipeError:  # the parent closed: nobody wants it
            break
    if sensors is not None:
        sensors.close()


if __name__ == "__main__":
    _serve(*sys.argv[1:3])
