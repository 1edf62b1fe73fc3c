"""A Python module run as a child process that answers pickled requests over a pair of pipes.

The robot worker runs its slow, lock-holding computations this way (the gait planner, the sensors): `subprocess`
rather than `multiprocessing`, because the worker may itself be a daemon process, which may not have children.
The child reads requests until its request pipe closes, so closing is how it is told to exit.
"""

from __future__ import annotations

import contextlib
import os
import pickle
import subprocess
import sys
from typing import IO, Any


class PipedChild:
    """`python -m module *args <request fd> <answer fd>`; `send` a request, `receive` its answer."""

    def __init__(self, module: str, *args: str, quiet: bool = False) -> None:
        request_read, request_write = os.pipe()
        answer_read, answer_write = os.pipe()
        self.process = subprocess.Popen(
            [sys.executable, "-m", module, *args, str(request_read), str(answer_write)],
            pass_fds=(request_read, answer_write),
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL if quiet else None,
        )
        os.close(request_read)
        os.close(answer_write)
        self._requests: IO[bytes] = os.fdopen(request_write, "wb")
        self._answers: IO[bytes] = os.fdopen(answer_read, "rb")

    def send(self, request: Any) -> None:
        pickle.dump(request, self._requests)
        self._requests.flush()

    def receive(self) -> Any:
        return pickle.load(self._answers)

    def close(self) -> None:
        with contextlib.suppress(OSError):
            self._requests.close()
        try:
            self.process.wait(timeout=5)
        except subprocess.TimeoutExpired:
            self.process.kill()
        self._answers.close()
