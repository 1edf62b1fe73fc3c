"""The per-user cache every process of the app shares (the placo model, the simplified meshes): made once per
machine, kept across runs, and never a directory per process (a process killed outright leaves nothing behind)."""

from __future__ import annotations

from pathlib import Path

import platformdirs


def user_cache_dir(part: str) -> Path:
    """`part` of the app's per-user cache (on Linux `$XDG_CACHE_HOME/humanoid/part`, else `~/.cache/...`)."""
    return Path(platformdirs.user_cache_dir("humanoid")) / part
