"""The same sessions store on PostgreSQL (DATABASE_URL=postgresql+psycopg://...), against a real server that the
test starts from Debian's package: migrations up and down, recording, filters, deletion, export and import."""

from __future__ import annotations

from pathlib import Path

import pytest
from alembic import command
from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext
from sqlalchemy import inspect

from app.sessions.db import alembic_config, make_engine, make_session_factory, upgrade_to_head
from app.sessions.maintenance import delete_sessions
from app.sessions.models import Base
from app.sessions.queries import SessionFilter, list_sessions, session_detail
from tests.app.session_helpers import record_session
from tests.app.test_session_store import check_json_round_trip, check_mcap
from tests.support.postgres_server import postgres_server

pytest.importorskip("psycopg")


@pytest.fixture(scope="module")
def postgres_url():
    with postgres_server() as url:
        yield url


def test_migrations_build_the_schema_on_postgres_and_take_it_down_again(postgres_url: str) -> None:
    upgrade_to_head(postgres_url)
    engine = make_engine(postgres_url)
    with engine.connect() as connection:
        assert compare_metadata(MigrationContext.configure(connection), Base.metadata) == []
    command.downgrade(alembic_config(postgres_url), "base")
    assert set(inspect(engine).get_table_names()) <= {"alembic_version"}
    engine.dispose()


def test_sessions_are_recorded_reviewed_exported_and_deleted_on_postgres(
    postgres_url: str, make_worker, tmp_path: Path
) -> None:
    upgrade_to_head(postgres_url)
    engine = make_engine(postgres_url)
    factory = make_session_factory(engine)
    audio_dir = str(tmp_path / "audio")
    sid = record_session(factory, make_worker(realtime=False), audio_dir)
    with factory() as db:
        detail = session_detail(db, sid)
        assert detail["telemetry"]["samples"] > 30 and detail["estop_count"] == 1
        assert [s["id"] for s in list_sessions(db, SessionFilter(text="hello", had_estop=True))[0]] == [sid]
    check_json_round_trip(factory, audio_dir, sid, tmp_path)
    check_mcap(factory, sid, tmp_path / "s.mcap")
    with factory() as db:
        ids = [s["id"] for s in list_sessions(db)[0]]
    assert delete_sessions(factory, audio_dir, ids) == 2
    with factory() as db:
        assert list_sessions(db)[1] == 0
    engine.dispose()
