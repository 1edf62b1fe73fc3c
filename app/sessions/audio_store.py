"""Recordings kept with their session: WAV files under the audio directory, one folder per session, referred to
from the DB by a path relative to that directory (so the directory can move)."""

from __future__ import annotations

import shutil
import uuid
from pathlib import Path


def save_recording(audio_dir: str | Path, session_id: int, wav: bytes) -> str:
    """Write the WAV; returns its path relative to `audio_dir`."""
    relative = Path(str(session_id)) / f"{uuid.uuid4().hex}.wav"
    target = Path(audio_dir) / relative
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_bytes(wav)
    return relative.as_posix()


def recording_file(audio_dir: str | Path, relative: str) -> Path | None:
    """The file a stored reference names, if it exists and lies inside the audio directory."""
    root = Path(audio_dir).resolve()
    path = (root / relative).resolve()
    return path if path.is_relative_to(root) and path.is_file() else None


def keep_recording(audio_dir: str | Path, session_id: int, source: str | Path) -> str | None:
    """Move a recording made elsewhere (the robot's microphone spools each utterance) into the session's folder;
    its relative path, or None when the file is gone."""
    source = Path(source)
    if not source.is_file():
        return None
    relative = Path(str(session_id)) / f"{uuid.uuid4().hex}.wav"
    target = Path(audio_dir) / relative
    target.parent.mkdir(parents=True, exist_ok=True)
    shutil.move(str(source), target)
    return relative.as_posix()


def delete_session_audio(audio_dir: str | Path, session_id: int) -> None:
    """Remove a deleted session's recordings (its folder)."""
    folder = Path(audio_dir) / str(session_id)
    if folder.is_dir():
        shutil.rmtree(folder, ignore_errors=True)
