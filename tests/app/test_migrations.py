"""The schema comes from alembic, and the migrations match the models."""

from __future__ import annotations

import json

import numpy as np
import pytest
from alembic import command
from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext
from sqlalchemy import create_engine, inspect, text

from app.sessions.db import alembic_config, make_session_factory, upgrade_to_head
from app.sessions.models import Base
from app.sessions.queries import load_telemetry


def test_upgrade_creates_the_schema_and_matches_the_models(tmp_path) -> None:
    url = f"sqlite:///{tmp_path / 'nested' / 'm.db'}"
    upgrade_to_head(url)  # also creates the missing directory
    engine = create_engine(url)
    tables = set(inspect(engine).get_table_names())
    assert {
        "sessions",
        "commands",
        "plans",
        "step_results",
        "events",
        "transcripts",
        "telemetry_chunks",
        "camera_frames",
        "lidar_scans",
        "occupancy_maps",
    } <= tables
    with engine.connect() as connection:
        diff = compare_metadata(MigrationContext.configure(connection), Base.metadata)
    assert diff == []
    upgrade_to_head(url)  # idempotent
    command.downgrade(alembic_config(url), "base")
    assert set(inspect(engine).get_table_names()) <= {"alembic_version"}
    engine.dispose()


def test_state_samples_of_old_sessions_become_telemetry_and_come_back_on_downgrade(tmp_path) -> None:
    url = f"sqlite:///{tmp_path / 'old.db'}"
    config = alembic_config(url)
    command.upgrade(config, "0002")
    engine = create_engine(url)
    qpos = [[0.1 * i, 0.2, 0.3, 1.0, 0.0, 0.0, 0.0, 0.5] for i in range(25)]
    with engine.begin() as connection:
        connection.execute(
            text(
                "INSERT INTO sessions (id, kind, started_at, seed, backend) "
                "VALUES (1, 'serve', '2026-11-20 10:00:00', 0, 'sim')"
            )
        )
        for i, q in enumerate(qpos):
            connection.execute(
                text(
                    "INSERT INTO state_samples (session_id, wall_time, sim_time_s, mode, x, y, z, yaw_rad, tilt_deg,"
                    " qpos) VALUES (1, :wall, :sim, 'idle', :x, 0.2, 0.3, 0, 0, :qpos)"
                ),
                {"wall": f"2026-11-20 10:00:{i:02d}", "sim": i * 0.1, "x": q[0], "qpos": json.dumps(q)},
            )
    upgrade_to_head(url)
    factory = make_session_factory(engine)
    with factory() as db:
        layout, rows = load_telemetry(db, 1)
    assert layout.slices()["qpos"] == slice(2, 10) and rows.shape == (25, 10)
    assert np.allclose(rows[:, 2:], qpos, atol=1e-6) and np.allclose(rows[:, 0], np.arange(25) * 0.1)
    engine.dispose()  # (a pooled connection would still see the tables as they were before the downgrade)
    command.downgrade(config, "0002")
    with engine.connect() as connection:
        back = connection.execute(text("SELECT sim_time_s, x, qpos FROM state_samples ORDER BY id")).all()
    assert len(back) == 25 and back[3].x == pytest.approx(0.3) and json.loads(back[3].qpos)[0] == pytest.approx(0.3)
    engine.dispose()
