"""The per-user cache every process of the app shares (the placo model, the simplified meshes): made once per
machine, kept across runs, and never a directory per process (a process killed outright leaves nothing behind)."""

from __future__ import annotations

import contextlib
import fcntl
from collections.abc import Iterator
from pathlib import Path

import platformdirs


def user_cache_dir(part: str) -> Path:
    """`part` of the app's per-user cache (on Linux `$XDG_CACHE_HOME/humanoid/part`, else `~/.cache/...`)."""
    return Path(platformdirs.user_cache_dir("humanoid")) / part


@contextlib.contextmanager
def cache_lock(directory: Path, name: str) -> Iterator[None]:
    """Held while one process makes something in `directory`: processes starting together wait, then read it."""
    with (directory / f".{name}.lock").open("a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)
