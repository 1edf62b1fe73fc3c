"""The scene's MJCF text, kept in the per-user cache.

Writing the text compiles the model with the robot's drawn meshes: ~0.7 s of CPU and ~340 MB at its peak, paid by
the robot process when it describes itself, by each `humanoid run` and by each replay, for a text that changes only
with the world, the code that builds it and the packages it comes from. Those name the cached copy, so a change to
any of them makes a new one; a copy is only ever written whole (a rename), and one that names a mesh file no longer
there is made again.
"""

from __future__ import annotations

import hashlib
import logging
import os
import re
import tempfile
from collections.abc import Callable
from pathlib import Path

import mujoco

from robot.user_cache import user_cache_dir

log = logging.getLogger(__name__)

_FILE = re.compile(r'\bfile="([^"]+)"')
_MESHDIR = re.compile(r'\bmeshdir="([^"]+)"')


def _model_sources() -> str:
    """What the scene is built by: this package's sources, and the MuJoCo that writes the text."""
    digest = hashlib.sha256(mujoco.__version__.encode())
    for path in sorted(Path(__file__).parent.glob("*.py")):
        digest.update(path.name.encode() + path.read_bytes())
    return digest.hexdigest()


def _files_present(xml: str) -> bool:
    """Whether every file the text names (meshes, relative to its mesh directory or absolute) is there."""
    meshdir = _MESHDIR.search(xml)
    base = Path(meshdir.group(1)) if meshdir else Path()
    return all((base / name).is_file() for name in _FILE.findall(xml))


def cached_scene_xml(name: str, recipe: str, make: Callable[[], str], directory: Path | None = None) -> str:
    """The text `make()` writes for `recipe` (what it depends on besides the code and packages), from the cache
    when a whole, current copy is there; made and kept otherwise. `name` only helps a person reading the cache."""
    if directory is None:
        directory = user_cache_dir("scenes")
    key = hashlib.sha256(f"{recipe};{_model_sources()}".encode()).hexdigest()[:16]
    path = directory / f"{name}_{key}.xml"
    try:
        xml = path.read_text()
        if _files_present(xml):
            return xml
    except OSError:
        pass
    xml = make()
    part = None
    try:
        directory.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile("w", dir=directory, suffix=".part", delete=False) as out:
            part = out.name
            out.write(xml)
        os.replace(part, path)
    except OSError as exc:  # no writable cache (a service account): made every time, as before
        log.info("scene not cached (%s)", exc)
        if part is not None:
            Path(part).unlink(missing_ok=True)
    return xml
