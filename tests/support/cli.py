"""The `humanoid` command as a user runs it: a process of its own, with this test run's Python and settings."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from typing import Any


def humanoid(*args: str, env: dict[str, str] | None = None, timeout_s: float = 600.0) -> subprocess.CompletedProcess:
    """`humanoid ARGS...` run to its end; `env` adds to (or overrides) this process's environment."""
    return subprocess.run(
        [sys.executable, "-m", "app.cli", *args],
        capture_output=True,
        text=True,
        env={**os.environ, **(env or {})},
        timeout=timeout_s,
    )


def bench(suite: str, *args: str, timeout_s: float = 900.0) -> dict[str, Any]:
    """`humanoid bench SUITE ARGS... --json`, its JSON result (an assertion error with its stderr if it failed)."""
    done = humanoid("bench", suite, *args, "--json", timeout_s=timeout_s)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout)
