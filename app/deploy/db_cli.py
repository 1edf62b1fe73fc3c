"""`humanoid db upgrade [--backup] | backup FILE`: migrations, and copies of the database that upgrades keep."""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from app.settings import Settings

NOT_DONE = 3  # PostgreSQL: the backup command is said, not run


def _upgrade(args: argparse.Namespace, settings: Settings) -> int:
    from app.deploy.backup import BackupError, UnknownRevision, upgrade_with_backup
    from app.sessions.db import upgrade_to_head

    if not args.backup:
        upgrade_to_head(settings.database_url)
        print(f"database at head: {settings.database_url}")
        return 0
    try:
        outcome = upgrade_with_backup(settings.database_url, args.keep)
    except (BackupError, UnknownRevision) as exc:
        print(f"humanoid db upgrade: {exc}; nothing migrated", file=sys.stderr)
        return 1
    if outcome.backup is not None:
        print(f"backed up to {outcome.backup} (migration {outcome.before})")
    for old in outcome.removed:
        print(f"removed the older backup {old}")
    if outcome.note:
        print(outcome.note, file=sys.stderr)
    moved = "already" if outcome.before == outcome.head else f"{outcome.before or 'empty'} ->"
    print(f"database at head ({moved} {outcome.head}): {settings.database_url}")
    return 0


def _backup(args: argparse.Namespace, settings: Settings) -> int:
    from app.deploy.backup import BackupError, backup_sqlite, pg_dump_command, sqlite_file

    database = sqlite_file(settings.database_url)
    target = Path(args.file)
    if database is None:
        print(shlex.join(pg_dump_command(settings.database_url, str(target))))
        print(
            "not a SQLite database: back it up with the command above (the password from PGPASSWORD or "
            "~/.pgpass); restore with pg_restore",
            file=sys.stderr,
        )
        return NOT_DONE
    if target.exists() and not args.force:
        print(f"{target} exists; --force to overwrite it", file=sys.stderr)
        return 1
    try:
        backup_sqlite(database, target)
    except BackupError as exc:
        print(f"humanoid db backup: {exc}", file=sys.stderr)
        return 1
    print(f"backed up {database} to {target} ({target.stat().st_size / 1e6:.1f} MB)")
    return 0


def add_db_parser(sub: argparse._SubParsersAction) -> None:
    db = sub.add_parser("db", help="database maintenance: migrations, backups")
    commands = db.add_subparsers(dest="db_command", required=True)
    upgrade = commands.add_parser("upgrade", help="apply pending migrations")
    upgrade.add_argument(
        "--backup",
        action="store_true",
        help="first back up a SQLite database that has migrations to run (to backups/ beside it)",
    )
    upgrade.add_argument("--keep", type=int, default=5, help="with --backup: how many backups to keep (5)")
    upgrade.set_defaults(func=_upgrade)
    backup = commands.add_parser("backup", help="copy the database to FILE (SQLite; PostgreSQL: the pg_dump command)")
    backup.add_argument("file")
    backup.add_argument("--force", action="store_true", help="overwrite FILE")
    backup.set_defaults(func=_backup)
