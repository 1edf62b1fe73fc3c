"""Fixtures of the web side's tests."""

from __future__ import annotations

from pathlib import Path

import pytest

from app.sessions.db import make_engine, make_session_factory, upgrade_to_head


@pytest.fixture
def store(tmp_path: Path):
    url = f"sqlite:///{tmp_path / 'sessions.db'}"
    upgrade_to_head(url)
    engine = make_engine(url)
    yield make_session_factory(engine), str(tmp_path / "audio")
    engine.dispose()
