"""Database backups, and migrations that keep data: a SQLite file is copied with SQLite's online backup API (a
consistent copy even while the server writes) before any pending migration runs, and only the last few copies
are kept. PostgreSQL is backed up with its own tool, pg_dump: we say the command."""

from __future__ import annotations

import contextlib
import shutil
import sqlite3
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

from alembic.runtime.migration import MigrationContext
from alembic.script import ScriptDirectory
from sqlalchemy.engine import URL, make_url

from app.sessions.db import alembic_config, make_engine, upgrade_to_head

BACKUP_PREFIX = "humanoid-"
SPACE_MARGIN = 1.1  # a backup needs the file's size, and a little more


class BackupError(RuntimeError):
    """A backup that could not be made: nothing was migrated."""


class UnknownRevision(RuntimeError):
    """The database was migrated by a newer version of this code: migrating it is refused."""


def sqlite_file(url: str) -> Path | None:
    """The SQLite file a URL names, or None (another database, or in memory)."""
    parsed = make_url(url)
    if parsed.get_backend_name() != "sqlite" or not parsed.database or parsed.database == ":memory:":
        return None
    return Path(parsed.database)


def pg_dump_command(url: str, target: str) -> list[str]:
    """pg_dump for a PostgreSQL URL; its password stays out of the command line (PGPASSWORD or ~/.pgpass)."""
    given = make_url(url)
    plain = URL.create(
        "postgresql",
        username=given.username,
        host=given.host,
        port=given.port,
        database=given.database,
        query=given.query,
    )
    return ["pg_dump", "--format=custom", f"--file={target}", f"--dbname={plain.render_as_string()}"]


def backup_sqlite(source: Path, target: Path) -> Path:
    """A consistent copy of `source` at `target` (written aside, then renamed: never half a file)."""
    if not source.exists():
        raise BackupError(f"{source} does not exist")
    needed = source.stat().st_size * SPACE_MARGIN
    target.parent.mkdir(parents=True, exist_ok=True)
    free = shutil.disk_usage(target.parent).free
    if free < needed:
        raise BackupError(
            f"{target.parent} has {free / 1e6:.0f} MB free; a backup of {source} needs {needed / 1e6:.0f} MB"
        )
    partial = target.with_name(target.name + ".partial")
    try:
        with contextlib.closing(sqlite3.connect(source)) as src, contextlib.closing(sqlite3.connect(partial)) as dst:
            src.backup(dst)
        partial.replace(target)
    except sqlite3.Error as exc:
        partial.unlink(missing_ok=True)
        raise BackupError(f"cannot back up {source}: {exc}") from exc
    return target


def revisions(url: str) -> tuple[str | None, str]:
    """(the database's migration revision, None when it has none yet; the code's newest). UnknownRevision when
    the database's is not among the code's."""
    scripts = ScriptDirectory.from_config(alembic_config(url))
    engine = make_engine(url)
    try:
        with engine.connect() as connection:
            current = MigrationContext.configure(connection).get_current_revision()
    finally:
        engine.dispose()
    if current is not None and current not in {s.revision for s in scripts.walk_revisions()}:
        raise UnknownRevision(
            f"the database is at migration {current}, which this version of the code does not "
            "know (a newer version migrated it): update the code, or restore a backup"
        )
    return current, str(scripts.get_current_head())


def rotate(folder: Path, keep: int) -> list[Path]:
    """Deletes all but the newest `keep` backups in `folder`; returns the deleted ones."""
    backups = sorted(folder.glob(f"{BACKUP_PREFIX}*.db"))
    old = backups[:-keep] if keep > 0 else backups
    for path in old:
        path.unlink()
    return old


@dataclass(frozen=True)
class UpgradeOutcome:
    before: str | None
    head: str
    backup: Path | None
    removed: list[Path]
    note: str = ""


def upgrade_with_backup(url: str, keep: int) -> UpgradeOutcome:
    """Migrations to head; first, when there are any to run on a SQLite file with data, a backup of it next to
    it (backups/), keeping the newest `keep`. A backup that fails stops everything (BackupError)."""
    before, head = revisions(url)
    database = sqlite_file(url)
    backup = None
    removed: list[Path] = []
    note = ""
    if before != head and before is not None:
        if database is not None:
            stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%S%fZ")
            folder = database.parent / "backups"
            backup = backup_sqlite(database, folder / f"{BACKUP_PREFIX}{stamp}-{before}.db")
            removed = rotate(folder, keep)
        else:
            note = "no backup made of a database that is not SQLite: pg_dump it before upgrading"
    upgrade_to_head(url)
    return UpgradeOutcome(before, head, backup, removed, note)
