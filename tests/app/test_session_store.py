"""Sessions as stored: what a recorder writes, how the list is filtered, the timeline, deletion and retention,
crash recovery, export to JSON and MCAP and import back. Runs on SQLite here and on PostgreSQL in
test_postgres.py (the same checks, through `check_store_round_trip`)."""

from __future__ import annotations

import itertools
import json
import os
import socket
import subprocess
import time
from datetime import UTC, datetime, timedelta
from pathlib import Path

import numpy as np
import pytest
from sqlalchemy import func, select

from app.sessions.archive import ArchiveError, export_session_json, import_session, read_archive
from app.sessions.db import make_engine, make_session_factory, upgrade_to_head
from app.sessions.maintenance import apply_retention, close_interrupted_sessions, delete_sessions
from app.sessions.mcap_export import export_session_mcap
from app.sessions.models import (
    CommandRow,
    EventRow,
    SessionRow,
    TelemetryChunkRow,
    TranscriptRow,
)
from app.sessions.queries import SessionFilter, list_sessions, load_telemetry, session_detail, telemetry_series
from tests.app.session_helpers import record_session


@pytest.fixture
def recorded(store, make_worker):
    factory, audio_dir = store
    return factory, audio_dir, record_session(factory, make_worker(realtime=False), audio_dir)


def test_a_session_records_motion_at_30_hz_of_simulated_time_and_what_happened(recorded) -> None:
    factory, _, sid = recorded
    with factory() as db:
        layout, rows = load_telemetry(db, sid)
        detail = session_detail(db, sid)
    sim = rows[:, 0]
    assert np.all(np.diff(sim) > 0) and np.median(np.diff(sim)) == pytest.approx(0.03, abs=1e-6)  # 33 Hz
    assert sim[-1] - sim[0] > 1.4
    assert detail["telemetry"]["samples"] == len(rows) and detail["telemetry"]["rate_hz"] >= 30
    assert set(layout.slices()) >= {"qpos", "joint_target", "joint_position", "com", "battery_v", "tick_ms"}
    kinds = [i["type"] for i in detail["timeline"]]
    assert kinds.count("command") == 2 and "heard" in kinds and "plan" in kinds and "step" in kinds
    assert "estop" in kinds
    refused = next(i for i in detail["timeline"] if i["type"] == "command" and "moon" in i["text"])
    assert "refused" in refused["text"]
    heard = next(i for i in detail["timeline"] if i["type"] == "heard")
    assert heard["audio_url"].endswith("/audio.wav")
    assert heard["text"].startswith('heard "say hello", or "say hollow"')  # the other wording is kept too
    assert detail["transcripts"][0]["alternatives"] == ["say hollow"]
    times = [i["sim_time_s"] for i in detail["timeline"]]
    # in time order (to the centisecond: a command comes before the plan made of it at the same moment)
    assert all(b >= a - 0.01 for a, b in itertools.pairwise(times))
    # (diagnostics alarms come from a wall-clock monitor, e.g. a loaded machine's CPU: they may land after the
    # last telemetry sample of a headless run, whose simulated time runs several times faster than the wall's)
    recorded_times = [i["sim_time_s"] for i in detail["timeline"] if i["type"] != "alarm"]
    assert all(sim[0] - 1 <= t <= sim[-1] + 1 for t in recorded_times)
    with factory() as db:
        series = telemetry_series(db, sid, ["battery_v", "com"], max_points=20)
    assert len(series["sim_time_s"]) <= 20 and len(series["com"]) == 3
    assert 20.0 < series["battery_v"][0][-1] < 25.3


def test_the_list_filters_by_date_outcome_text_estop_and_fall(recorded, make_worker) -> None:
    factory, audio_dir, sid = recorded
    quiet = record_session(factory, make_worker(realtime=False), audio_dir, estop=False)
    with factory() as db:
        db.add(
            EventRow(
                session_id=quiet,
                seq=10_000,
                kind="robot/fell",
                level=2,
                message="the robot fell",
                wall_time=datetime.now(UTC),
                sim_time_s=1.0,
            )
        )
        db.execute(SessionRow.__table__.update().where(SessionRow.id == quiet).values(outcome="failed"))
        db.commit()

    def ids(**kw) -> list[int]:
        with factory() as db:
            return [s["id"] for s in list_sessions(db, SessionFilter(**kw))[0]]

    assert ids() == [quiet, sid]
    assert ids(had_estop=True) == [sid] and ids(had_estop=False) == [quiet]
    assert ids(had_fall=True) == [quiet] and ids(had_fall=False) == [sid]
    assert ids(outcome="failed") == [quiet] and ids(outcome="succeeded") == [sid]
    assert ids(text="MOON") == [quiet, sid] and ids(text="dance") == []
    now = datetime.now(UTC)
    assert (
        ids(started_from=now - timedelta(hours=1)) == [quiet, sid] and ids(started_from=now + timedelta(hours=1)) == []
    )
    with factory() as db:
        page, total = list_sessions(db, limit=1, offset=1)
    assert total == 2 and [s["id"] for s in page] == [sid] and page[0]["estop_count"] == 1
    assert page[0]["first_command"] == "say hello"


def test_deleting_a_session_removes_all_it_recorded_and_its_recordings(recorded) -> None:
    factory, audio_dir, sid = recorded
    assert (Path(audio_dir) / str(sid)).is_dir()
    assert delete_sessions(factory, audio_dir, [sid]) == 1
    with factory() as db:
        for table in (SessionRow, CommandRow, EventRow, TelemetryChunkRow, TranscriptRow):
            assert db.scalar(select(func.count()).select_from(table)) == 0, table.__tablename__
    assert not (Path(audio_dir) / str(sid)).exists()


def test_retention_deletes_old_and_surplus_sessions_but_never_the_live_one(store) -> None:
    factory, audio_dir = store
    now = datetime.now(UTC)
    with factory() as db:
        rows = [
            SessionRow(
                kind="run",
                seed=0,
                backend="sim",
                started_at=now - timedelta(days=age),
                ended_at=now - timedelta(days=age),
            )
            for age in (40, 20, 5, 1)
        ]
        live = SessionRow(kind="serve", seed=0, backend="sim", started_at=now - timedelta(days=60))
        db.add_all([*rows, live])
        db.commit()
        old, middle, recent, newest = (r.id for r in rows)
    assert apply_retention(factory, audio_dir, max_age_days=30, max_count=0, keep={live.id}) == [old]
    assert apply_retention(factory, audio_dir, max_age_days=0, max_count=3, keep={live.id}) == [middle]
    with factory() as db:
        assert sorted(db.scalars(select(SessionRow.id))) == sorted([recent, newest, live.id])


def test_a_session_left_open_by_a_crash_is_closed_as_interrupted_at_its_last_record(store) -> None:
    factory, _ = store
    now = datetime.now(UTC)
    with factory() as db:
        crashed = SessionRow(
            kind="serve",
            seed=0,
            backend="sim",
            started_at=now - timedelta(hours=1),
            heartbeat_at=now - timedelta(minutes=30),
        )
        alive = SessionRow(
            kind="serve",
            seed=0,
            backend="sim",
            started_at=now - timedelta(hours=1),
            heartbeat_at=now - timedelta(seconds=2),
        )
        here = {"recorder_host": socket.gethostname(), "heartbeat_at": now, "started_at": now}
        killed = SessionRow(kind="serve", seed=0, backend="sim", recorder_pid=_dead_pid(), **here)
        ours = SessionRow(kind="serve", seed=0, backend="sim", recorder_pid=os.getpid(), **here)
        db.add_all([crashed, alive, killed, ours])
        db.flush()
        db.add(
            EventRow(
                session_id=crashed.id,
                seq=1,
                kind="x",
                level=0,
                message="last words",
                wall_time=now - timedelta(minutes=29),
                sim_time_s=5.0,
            )
        )
        db.commit()
    assert sorted(close_interrupted_sessions(factory)) == [crashed.id, killed.id]  # the killed one at once
    with factory() as db:
        row = db.get(SessionRow, crashed.id)
        assert row.outcome == "interrupted"
        assert abs((row.ended_at.replace(tzinfo=UTC) - (now - timedelta(minutes=29))).total_seconds()) < 1
        assert db.get(SessionRow, alive.id).ended_at is None  # another server's live session
        assert db.get(SessionRow, ours.id).ended_at is None


def _dead_pid() -> int:
    process = subprocess.Popen(["true"])
    process.wait()
    return process.pid


def check_json_round_trip(factory, audio_dir: str, sid: int, tmp_path: Path) -> None:
    first, second = tmp_path / "a.json", tmp_path / "b.json"
    export_session_json(factory, sid, first, audio_dir)
    new_id = import_session(factory, read_archive(first), audio_dir)
    assert new_id != sid
    export_session_json(factory, new_id, second, audio_dir)
    a, b = json.loads(first.read_text()), json.loads(second.read_text())
    for key in ("commands", "transcripts", "plans", "step_results", "events", "camera_frames"):
        assert a[key] == b[key], key
    ta, tb = np.array(a["telemetry"], dtype=float), np.array(b["telemetry"], dtype=float)
    assert ta.shape == tb.shape and ta.shape[0] > 30
    assert np.allclose(ta, tb, equal_nan=True, rtol=1e-6)
    assert a["transcripts"][0]["audio_wav_base64"]  # the recording travels with it
    assert a["transcripts"][0]["alternatives"] == ["say hollow"]
    with factory() as db:
        assert session_detail(db, new_id)["kind"] == "import"


def test_export_to_json_and_import_give_the_same_session_back(recorded, tmp_path: Path) -> None:
    factory, audio_dir, sid = recorded
    check_json_round_trip(factory, audio_dir, sid, tmp_path)


@pytest.mark.parametrize(
    ("document", "fragment"),
    [
        (b"{not json", "not JSON"),
        (b'{"format": "something else"}', "not a session export"),
        (b'{"format": "humanoid-mission-control/session", "version": 99}', "version 99"),
        (b'{"format": "humanoid-mission-control/session", "version": 1, "session": {}}', 'no "commands"'),
    ],
)
def test_a_document_that_is_not_a_session_export_is_refused_with_the_reason(document: bytes, fragment: str) -> None:
    with pytest.raises(ArchiveError, match=fragment):
        read_archive(document)


def test_a_malformed_export_imports_nothing(recorded, tmp_path: Path) -> None:
    factory, audio_dir, sid = recorded
    path = tmp_path / "a.json"
    export_session_json(factory, sid, path, audio_dir)
    doc = json.loads(path.read_text())
    doc["telemetry"][3] = doc["telemetry"][3][:5]  # a row cut short
    with pytest.raises(ArchiveError):
        import_session(factory, doc, audio_dir)
    del doc["events"][0]["kind"]
    doc["telemetry"] = []
    with pytest.raises(ArchiveError, match="malformed"):
        import_session(factory, doc, audio_dir)
    with factory() as db:
        assert db.scalar(select(func.count(SessionRow.id))) == 1


def check_mcap(factory, sid: int, path: Path) -> None:
    from mcap.reader import make_reader
    from mcap_protobuf.decoder import DecoderFactory

    counts = export_session_mcap(factory, sid, path)
    with factory() as db:
        _, rows = load_telemetry(db, sid)
    with path.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()], validate_crcs=True)
        summary = reader.get_summary()
        schemas = {c.topic: summary.schemas[c.schema_id].name for c in summary.channels.values()}
        assert schemas["/tf"] == "foxglove.FrameTransforms" and schemas["/joint_states"] == "foxglove.JointStates"
        assert schemas["/log"] == "foxglove.Log" and schemas["/scene"] == "foxglove.SceneUpdate"
        assert schemas["/robot_description"] == "std_msgs/String"  # as the 3D panels' URDF layer reads it
        seen: dict[str, int] = {}
        last_time = 0
        for _, channel, message, decoded in reader.iter_decoded_messages(topics=["/tf", "/joint_states", "/log"]):
            assert message.log_time >= last_time  # written in time order
            last_time = message.log_time
            seen[channel.topic] = seen.get(channel.topic, 0) + 1
            if channel.topic == "/joint_states" and seen[channel.topic] == 1:
                assert "r_knee" in [j.name for j in decoded.joints]
            if channel.topic == "/tf" and seen[channel.topic] == 1:
                children = {t.child_frame_id: t.parent_frame_id for t in decoded.transforms}
                assert children["body_link"] == "world" and children["r_knee_link"] == "r_hip_pitch_link"
    assert seen["/tf"] == seen["/joint_states"] == len(rows) == counts["/tf"]
    assert counts["/robot_description"] == 1
    assert seen["/log"] == counts["/log"] >= 5


def test_mcap_export_has_standard_schemas_and_every_sample(recorded, tmp_path: Path) -> None:
    factory, _, sid = recorded
    check_mcap(factory, sid, tmp_path / "s.mcap")


def test_camera_frames_are_stored_at_a_quarter_of_the_pixels() -> None:
    import cv2

    from app.sessions.recorder import shrink_jpeg

    rng = np.random.default_rng(0)
    image = cv2.GaussianBlur(rng.integers(0, 255, (480, 640, 3), dtype=np.uint8), (9, 9), 3)
    jpeg = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, 90])[1].tobytes()
    small, width, height, scale = shrink_jpeg(jpeg, 640, 480, 320)
    assert (width, height, scale) == (320, 240, 0.5) and len(small) < len(jpeg) / 2
    assert cv2.imdecode(np.frombuffer(small, np.uint8), cv2.IMREAD_COLOR).shape == (240, 320, 3)
    assert shrink_jpeg(small, 320, 240, 320) == (small, 320, 240, 1.0)  # small enough already


def test_exported_transforms_compose_back_to_the_bodies_world_poses(scene_model) -> None:
    import mujoco

    from app.foxglove.frames import SceneFrames

    bodies = SceneFrames(scene_model)
    qpos = scene_model.qpos0.copy()
    qpos[:3] = (0.4, -0.3, 0.28)
    qpos[3:7] = (np.cos(0.3), 0.0, 0.0, np.sin(0.3))
    qpos[7:] += 0.2  # bend every joint a little
    translation, rotation = bodies.relative_poses(qpos, None)
    body = scene_model.body("r_ank_roll_link").id
    chain = []
    b = body
    while b != 0:
        chain.append(b)
        b = int(scene_model.body_parentid[b])
    position, frame = np.zeros(3), np.eye(3)
    for b in reversed(chain):  # world -> trunk -> ... -> ankle
        local = np.zeros(9)
        mujoco.mju_quat2Mat(local, rotation[b - 1])
        position = position + frame @ translation[b - 1]
        frame = frame @ local.reshape(3, 3)
    assert len(chain) >= 6
    assert np.allclose(position, bodies.data.xpos[body], atol=1e-9)
    assert np.allclose(frame, bodies.data.xmat[body].reshape(3, 3), atol=1e-9)


def test_a_session_closed_as_crashed_stays_crashed_when_the_server_closes_it_again(store, make_worker) -> None:
    from app.sessions.recorder import SessionRecorder

    factory, audio_dir = store
    recorder = SessionRecorder(factory, make_worker(realtime=False), kind="serve", seed=0, audio_dir=audio_dir)
    recorder.close(outcome="crashed", summary={"cause": "the robot process died (killed by SIGKILL)"})
    recorder.close()  # the server shutting down later (the supervisor had given up on the robot)
    with factory() as db:
        row = db.get(SessionRow, recorder.session_id)
        assert row.outcome == "crashed" and "SIGKILL" in row.summary["cause"]


def test_a_server_applies_retention_and_closes_crashed_sessions_as_it_starts(settings, make_worker) -> None:
    """Maintenance runs on the recorder's thread as soon as the live session is open (it once ran before the
    recorder it was given existed, failed, and waited minutes for its next turn)."""
    from app.runtime import Runtime

    upgrade_to_head(settings.database_url)
    engine = make_engine(settings.database_url)
    factory = make_session_factory(engine)
    now = datetime.now(UTC)
    with factory() as db:
        old = SessionRow(kind="run", seed=0, backend="sim", started_at=now - timedelta(days=40), ended_at=now)
        an_hour_ago = now - timedelta(hours=1)
        crashed = SessionRow(kind="serve", seed=0, backend="sim", started_at=an_hour_ago, heartbeat_at=an_hour_ago)
        db.add_all([old, crashed])
        db.commit()
        old_id, crashed_id = old.id, crashed.id
    runtime = Runtime.start(settings.model_copy(update={"session_retention_days": 30.0}), worker=make_worker())
    try:
        deadline = time.monotonic() + 30.0
        while True:
            with factory() as db:
                ids = set(db.scalars(select(SessionRow.id)))
                interrupted = db.get(SessionRow, crashed_id)
                ended = interrupted is not None and interrupted.ended_at is not None
            if old_id not in ids and ended:
                break
            assert time.monotonic() < deadline, f"sessions {sorted(ids)}; the crashed one ended: {ended}"
            time.sleep(0.05)
        assert runtime.recorder.session_id in ids  # never the live one
    finally:
        runtime.stop()
        engine.dispose()


def test_maintenance_is_told_the_live_session_it_must_keep(store, make_worker) -> None:
    """It runs on the recorder's thread, which starts inside the recorder's constructor: it is handed the live
    session's id rather than reading it from a recorder the caller may not hold yet."""
    from app.sessions.recorder import SessionRecorder

    factory, audio_dir = store
    told: list[int] = []
    recorder = SessionRecorder(
        factory, make_worker(realtime=False), kind="serve", seed=0, audio_dir=audio_dir, maintenance=told.append
    )
    try:
        deadline = time.monotonic() + 30.0
        while not told:
            assert time.monotonic() < deadline, "maintenance never ran"
            time.sleep(0.02)
        assert told[0] == recorder.session_id
    finally:
        recorder.close()
