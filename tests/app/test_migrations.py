"""The schema comes from alembic, and the migrations match the models."""

from __future__ import annotations

from alembic import command
from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext
from sqlalchemy import create_engine, inspect

from app.sessions.db import alembic_config, upgrade_to_head
from app.sessions.models import Base


def test_upgrade_creates_the_schema_and_matches_the_models(tmp_path) -> None:
    url = f"sqlite:///{tmp_path / 'nested' / 'm.db'}"
    upgrade_to_head(url)  # also creates the missing directory
    engine = create_engine(url)
    tables = set(inspect(engine).get_table_names())
    assert {"sessions", "commands", "plans", "step_results", "events", "state_samples"} <= tables
    with engine.connect() as connection:
        diff = compare_metadata(MigrationContext.configure(connection), Base.metadata)
    assert diff == []
    upgrade_to_head(url)  # idempotent
    command.downgrade(alembic_config(url), "base")
    assert set(inspect(engine).get_table_names()) <= {"alembic_version"}
    engine.dispose()
