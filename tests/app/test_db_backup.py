"""Upgrades keep data: `humanoid db backup FILE`, and `humanoid db upgrade --backup` (the service's ExecStartPre),
which copies a SQLite database before any pending migration and keeps the last few copies."""

from __future__ import annotations

import os
import sqlite3
import subprocess
import sys
import threading
from pathlib import Path

import pytest
from alembic import command
from alembic.script import ScriptDirectory

from app.deploy.backup import backup_sqlite
from app.sessions.db import alembic_config, upgrade_to_head

HUMANOID = Path(sys.executable).parent / "humanoid"

HEAD = ScriptDirectory.from_config(alembic_config("sqlite://")).get_current_head()  # the code's schema


def _cli(url: str, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [str(HUMANOID), *args], capture_output=True, text=True, timeout=120, env={**os.environ, "DATABASE_URL": url}
    )


def _database(path: Path, revision: str = "head", sessions: int = 3) -> str:
    url = f"sqlite:///{path}"
    command.upgrade(alembic_config(url), revision)
    with sqlite3.connect(path) as db:
        db.executemany(
            "INSERT INTO sessions (kind, started_at, seed, backend) VALUES ('serve', ?, ?, 'sim')",
            [(f"2026-11-0{i + 1} 10:00:00", i) for i in range(sessions)],
        )
    return url


def _read(path: Path) -> tuple[str, list[int]]:
    with sqlite3.connect(path) as db:
        (revision,) = db.execute("SELECT version_num FROM alembic_version").fetchone()
        seeds = [row[0] for row in db.execute("SELECT seed FROM sessions ORDER BY id")]
    return revision, seeds


def test_db_backup_copies_the_database(tmp_path: Path) -> None:
    url = _database(tmp_path / "humanoid.db")
    target = tmp_path / "copy.db"
    done = _cli(url, "db", "backup", str(target))
    assert done.returncode == 0, done.stderr
    assert _read(target) == (HEAD, [0, 1, 2])
    assert _cli(url, "db", "backup", str(target)).returncode == 1  # never overwritten unasked
    assert _cli(url, "db", "backup", str(target), "--force").returncode == 0


def test_a_backup_taken_while_the_server_writes_is_whole(tmp_path: Path) -> None:
    source = tmp_path / "humanoid.db"
    _database(source, sessions=0)
    writing = threading.Event()
    writing.set()

    def write() -> None:
        with sqlite3.connect(source, timeout=30) as db:
            db.execute("PRAGMA journal_mode=WAL")
            seed = 0
            while writing.is_set():
                db.execute(
                    "INSERT INTO sessions (kind, started_at, seed, backend) VALUES ('serve', '2026-11-01', ?, 'sim')",
                    (seed,),
                )
                db.commit()
                seed += 1

    writer = threading.Thread(target=write)
    writer.start()
    try:
        copies = [backup_sqlite(source, tmp_path / f"copy{i}.db") for i in range(5)]
    finally:
        writing.clear()
        writer.join()
    for copy in copies:
        with sqlite3.connect(copy) as db:
            assert db.execute("PRAGMA integrity_check").fetchone() == ("ok",)
            seeds = [row[0] for row in db.execute("SELECT seed FROM sessions ORDER BY id")]
        assert seeds == list(range(len(seeds)))  # a prefix of what was written: no row lost in between


def test_upgrade_backs_up_before_migrating_and_keeps_the_last_ones(tmp_path: Path) -> None:
    database = tmp_path / "humanoid.db"
    url = _database(database, revision="0003")  # a robot still on the previous release
    done = _cli(url, "db", "upgrade", "--backup", "--keep", "2")
    assert done.returncode == 0, done.stderr
    assert _read(database) == (HEAD, [0, 1, 2])  # migrated, sessions kept
    (backup,) = (tmp_path / "backups").glob("humanoid-*.db")
    assert _read(backup) == ("0003", [0, 1, 2])  # the database as it was before
    assert f"0003 -> {HEAD}" in done.stdout

    again = _cli(url, "db", "upgrade", "--backup", "--keep", "2")
    assert "already" in again.stdout and len(list((tmp_path / "backups").glob("*.db"))) == 1  # nothing to do

    for _ in range(3):  # three more releases, each with a migration
        command.downgrade(alembic_config(url), "0003")
        assert _cli(url, "db", "upgrade", "--backup", "--keep", "2").returncode == 0
    backups = sorted((tmp_path / "backups").glob("humanoid-*.db"))
    assert len(backups) == 2 and backup not in backups  # the newest two


def test_a_database_from_a_newer_release_is_left_alone(tmp_path: Path) -> None:
    database = tmp_path / "humanoid.db"
    url = _database(database)
    with sqlite3.connect(database) as db:
        db.execute("UPDATE alembic_version SET version_num = '0099'")
    done = _cli(url, "db", "upgrade", "--backup")
    assert done.returncode == 1
    assert "0099" in done.stderr and "does not know" in done.stderr and "nothing migrated" in done.stderr
    assert _read(database) == ("0099", [0, 1, 2])


def test_a_fresh_database_is_made_without_a_backup(tmp_path: Path) -> None:
    url = f"sqlite:///{tmp_path / 'new' / 'humanoid.db'}"
    done = _cli(url, "db", "upgrade", "--backup")
    assert done.returncode == 0, done.stderr
    assert not (tmp_path / "new" / "backups").exists()
    assert _read(tmp_path / "new" / "humanoid.db") == (HEAD, [])


def test_postgresql_gets_the_pg_dump_command_that_backs_it_up(tmp_path: Path) -> None:
    pytest.importorskip("psycopg")
    from tests.support.postgres_server import PostgresUnavailable, postgres_bin_dir, postgres_server

    try:
        bin_dir = postgres_bin_dir()
    except PostgresUnavailable as exc:
        pytest.skip(str(exc))
    hidden = _cli("postgresql+psycopg://robot:s3cret@db.example:5433/humanoid", "db", "backup", "out.dump")
    assert hidden.returncode == 3
    assert (
        hidden.stdout.strip()
        == "pg_dump --format=custom --file=out.dump --dbname=postgresql://robot@db.example:5433/humanoid"
    )
    assert "s3cret" not in hidden.stdout + hidden.stderr

    with postgres_server() as url:
        upgrade_to_head(url)
        said = _cli(url, "db", "backup", str(tmp_path / "humanoid.dump")).stdout.split()
        assert said[0] == "pg_dump"
        subprocess.run([str(bin_dir / "pg_dump"), *said[1:]], check=True, timeout=120)
        listing = subprocess.run(
            [str(bin_dir / "pg_restore"), "--list", str(tmp_path / "humanoid.dump")],
            capture_output=True,
            text=True,
            check=True,
        ).stdout
    assert "TABLE public sessions" in listing and "TABLE public users" in listing
