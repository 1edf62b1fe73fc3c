"""The 3D replay shows a stored session as it was recorded, and follows play, pause and seek."""

from __future__ import annotations

import time

import numpy as np
import pytest

from app.sessions.queries import load_telemetry
from app.viz.replay import ReplayError, SessionReplay
from tests.app.session_helpers import record_session


@pytest.fixture
def replay(store, make_worker):
    factory, audio_dir = store
    sid = record_session(factory, make_worker(realtime=False), audio_dir)
    viewer = SessionReplay(factory)
    yield viewer, factory, sid
    viewer.stop()


def test_seeking_shows_the_robot_where_it_was_at_that_time(replay) -> None:
    viewer, factory, sid = replay
    with factory() as db:
        layout, rows = load_telemetry(db, sid)
    status = viewer.load(sid)
    assert status.session_id == sid and status.samples == len(rows) and not status.playing
    assert status.start_s == pytest.approx(rows[0, 0]) and status.end_s == pytest.approx(rows[-1, 0])
    i = len(rows) // 2
    viewer.seek(float(rows[i, 0]))
    qpos = rows[i, layout.slices()["qpos"]]
    trunk = viewer._model.body("body_link").id  # the light scene has the recorded world's bodies
    assert np.allclose(viewer._data.xpos[trunk], qpos[:3], atol=1e-5)
    assert viewer.status().now  # the timeline entry in force is shown with the picture
    assert viewer.seek(-100.0).sim_time_s == pytest.approx(rows[0, 0], abs=1e-3)  # clamped to the recording


def test_playing_advances_at_the_chosen_speed_and_stops_at_the_end(replay) -> None:
    viewer, _, sid = replay
    status = viewer.load(sid)
    viewer.play(speed=2.0)
    time.sleep(0.6)
    moved = viewer.pause().sim_time_s - status.start_s
    assert 0.6 <= moved <= 3.0  # ~1.2 s of session time in 0.6 s (slack for a loaded machine)
    frames = viewer.frames
    time.sleep(0.3)
    assert viewer.frames == frames  # paused: nothing is sent
    viewer.seek(status.end_s - 0.1)
    viewer.play(speed=4.0)
    deadline = time.monotonic() + 5.0
    while viewer.status().playing and time.monotonic() < deadline:
        time.sleep(0.05)
    final = viewer.status()
    assert not final.playing and final.sim_time_s == pytest.approx(status.end_s, abs=1e-3)


def test_nothing_to_replay_is_said_plainly(replay) -> None:
    viewer, _, _ = replay
    with pytest.raises(ReplayError, match="no session is loaded"):
        viewer.seek(1.0)
    with pytest.raises(ReplayError, match="no session 999"):
        viewer.load(999)
