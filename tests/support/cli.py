"""The `humanoid` command as a user runs it: a process of its own, with this test run's Python and settings; or,
for a command that only reads and writes files and the database, in this process."""

from __future__ import annotations

import contextlib
import io
import json
import os
import subprocess
import sys
from typing import Any
from unittest import mock


def humanoid(*args: str, env: dict[str, str] | None = None, timeout_s: float = 600.0) -> subprocess.CompletedProcess:
    """`humanoid ARGS...` run to its end; `env` adds to (or overrides) this process's environment."""
    return subprocess.run(
        [sys.executable, "-m", "app.cli", *args],
        capture_output=True,
        text=True,
        env={**os.environ, **(env or {})},
        timeout=timeout_s,
    )


def humanoid_here(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    """`humanoid ARGS...` through its own entry point (parsing, settings from the environment, exit code, what it
    prints) in this process, whose modules are already loaded: ~2.5 s less than a process of its own. For commands
    that neither start the robot nor change process-wide state (sessions, plan, describe, refused arguments)."""
    from app.cli.commands import main
    from app.settings import get_settings

    out, err = io.StringIO(), io.StringIO()
    with mock.patch.dict(os.environ, env or {}), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        get_settings.cache_clear()  # the settings of this call's environment
        try:
            code = main(list(args))
        except SystemExit as exit:  # argparse refusing the arguments
            code = exit.code if isinstance(exit.code, int) else int(exit.code is not None)
        finally:
            get_settings.cache_clear()
    return subprocess.CompletedProcess(["humanoid", *args], code, out.getvalue(), err.getvalue())


def bench(suite: str, *args: str, timeout_s: float = 900.0) -> dict[str, Any]:
    """`humanoid bench SUITE ARGS... --json`, its JSON result (an assertion error with its stderr if it failed)."""
    done = humanoid("bench", suite, *args, "--json", timeout_s=timeout_s)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout)
