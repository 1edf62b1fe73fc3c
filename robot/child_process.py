"""A Python module run as a child process that answers pickled requests over a pair of pipes.

The robot worker runs its slow, lock-holding computations this way (the gait planner, the sensors): `subprocess`
rather than `multiprocessing`, because the worker may itself be a daemon process, which may not have children.
Messages are framed by `multiprocessing.connection.Connection`, so the parent can ask whether an answer has
arrived (`poll`) without blocking. The child reads requests until its request pipe closes, so closing is how it is
told to exit.
"""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
from multiprocessing.connection import Connection
from typing import Any


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
        self._requests = Connection(request_write, readable=False)
        self._answers = Connection(answer_read, writable=False)

    def send(self, request: Any) -> None:
        self._requests.send(request)

    def receive(self) -> Any:
        """The next answer, waiting for it (EOFError: the child is gone)."""
        return self._answers.recv()

    def answered(self) -> bool:
        """Whether an answer is waiting to be received (or the child is gone): `receive` will not wait."""
        return self._answers.poll(0)

    def close(self) -> None:
        """Tell the child to exit and drop what it has yet to answer (an answer nobody will read, say a walking plan
        an e-stop forgot, must not keep the child blocked on a full pipe)."""
        with contextlib.suppress(OSError):
            self._requests.close()
        self._answers.close()
        try:
            self.process.wait(timeout=5)
        except subprocess.TimeoutExpired:
            self.process.kill()


def child_ends(request_fd: str, answer_fd: str) -> tuple[Connection, Connection]:
    """The child's side: where its requests come from and where its answers go (`recv` raises EOFError, and `send`
    BrokenPipeError, once the parent has closed)."""
    return Connection(int(request_fd), writable=False), Connection(int(answer_fd), readable=False)
