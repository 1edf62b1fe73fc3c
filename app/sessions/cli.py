"""`humanoid sessions ...`: list, show, export, import and delete stored sessions from a terminal (the database
named by DATABASE_URL; no server needed)."""

from __future__ import annotations

import argparse
import json
import sys
from datetime import datetime
from typing import Any

from app.settings import Settings


def _factory(settings: Settings) -> Any:
    from app.sessions.db import make_engine, make_session_factory, upgrade_to_head

    upgrade_to_head(settings.database_url)
    return make_session_factory(make_engine(settings.database_url))


def _list(args: argparse.Namespace, settings: Settings) -> int:
    from app.sessions.queries import SessionFilter, list_sessions

    filters = SessionFilter(
        started_from=args.since,
        started_to=args.until,
        outcome=args.outcome,
        text=args.text,
        had_estop=args.had_estop,
        had_fall=args.had_fall,
        kind=args.kind,
    )
    with _factory(settings)() as db:
        items, total = list_sessions(db, filters, limit=args.limit, offset=args.offset)
    if args.json:
        print(json.dumps({"items": items, "total": total}, indent=2))
        return 0
    print(f"{total} sessions" + (f" (showing {len(items)})" if len(items) < total else ""))
    for s in items:
        print(
            f"{s['id']:>5}  {s['kind']:<6} {s['started_at'][:19]}  seed {s['seed']:<3} {s['outcome']:<11} "
            f"{s['command_count']} commands, {s['estop_count']} e-stops, {s['fall_count']} falls  "
            f"{s['first_command'] or ''}"
        )
    return 0


def _show(args: argparse.Namespace, settings: Settings) -> int:
    from app.sessions.queries import session_detail

    with _factory(settings)() as db:
        detail = session_detail(db, args.id)
    if detail is None:
        print(f"no session {args.id}", file=sys.stderr)
        return 1
    if args.json:
        print(json.dumps(detail, indent=2))
        return 0
    print(f"session {detail['id']} ({detail['kind']}, seed {detail['seed']}): {detail['outcome']}")
    for item in detail["timeline"]:
        t = f"{item['sim_time_s']:8.2f}" if item["sim_time_s"] is not None else "       -"
        print(f"  {t} s  {item['type']:<8} {item['text']}")
    return 0


def _export(args: argparse.Namespace, settings: Settings) -> int:
    from app.sessions.archive import export_session_json
    from app.sessions.mcap_export import export_session_mcap

    factory = _factory(settings)
    try:
        if args.format == "json":
            export_session_json(factory, args.id, args.output, settings.audio_dir)
        else:
            counts = export_session_mcap(factory, args.id, args.output)
            print(json.dumps({"topics": counts}), file=sys.stderr)
    except KeyError:
        print(f"no session {args.id}", file=sys.stderr)
        return 1
    print(f"session {args.id} written to {args.output} ({args.format})")
    return 0


def _import(args: argparse.Namespace, settings: Settings) -> int:
    from app.sessions.archive import ArchiveError, import_session, read_archive

    try:
        new_id = import_session(_factory(settings), read_archive(args.file), settings.audio_dir)
    except (ArchiveError, OSError) as exc:
        print(f"cannot import {args.file}: {exc}", file=sys.stderr)
        return 1
    print(json.dumps({"session_id": new_id}) if args.json else f"imported as session {new_id}")
    return 0


def _delete(args: argparse.Namespace, settings: Settings) -> int:
    from app.sessions.maintenance import delete_sessions
    from app.sessions.models import SessionRow

    factory = _factory(settings)
    with factory() as db:
        row = db.get(SessionRow, args.id)
        if row is None:
            print(f"no session {args.id}", file=sys.stderr)
            return 1
        if row.ended_at is None:
            print(f"session {args.id} is still being recorded: stop its server first", file=sys.stderr)
            return 1
    if not args.yes:
        print(f"delete session {args.id} and everything recorded in it? add --yes to confirm", file=sys.stderr)
        return 1
    delete_sessions(factory, settings.audio_dir, [args.id])
    print(f"deleted session {args.id}")
    return 0


def _flag(value: str) -> bool:
    if value.lower() in ("yes", "true", "1"):
        return True
    if value.lower() in ("no", "false", "0"):
        return False
    raise argparse.ArgumentTypeError("yes or no")


def add_sessions_parser(sub: argparse._SubParsersAction) -> None:
    from app.sessions.queries import OUTCOMES

    sessions = sub.add_parser("sessions", help="stored sessions: list, show, export, import, delete")
    commands = sessions.add_subparsers(dest="sessions_command", required=True)

    listing = commands.add_parser("list", help="sessions, newest first, optionally filtered")
    listing.add_argument("--json", action="store_true")
    listing.add_argument("--limit", type=int, default=50)
    listing.add_argument("--offset", type=int, default=0)
    listing.add_argument("--since", type=datetime.fromisoformat, default=None, help="started at or after (ISO 8601)")
    listing.add_argument("--until", type=datetime.fromisoformat, default=None, help="started at or before")
    listing.add_argument("--outcome", choices=OUTCOMES, default=None)
    listing.add_argument("--text", default=None, help="text in any of its commands")
    listing.add_argument("--had-estop", type=_flag, default=None, metavar="yes|no")
    listing.add_argument("--had-fall", type=_flag, default=None, metavar="yes|no")
    listing.add_argument("--kind", choices=["serve", "run", "import"], default=None)
    listing.set_defaults(func=_list)

    show = commands.add_parser("show", help="one session's timeline")
    show.add_argument("id", type=int)
    show.add_argument("--json", action="store_true", help="everything recorded but telemetry, as JSON")
    show.set_defaults(func=_show)

    export = commands.add_parser("export", help="write a session as JSON (importable) or MCAP (Foxglove)")
    export.add_argument("id", type=int)
    export.add_argument("--format", choices=["json", "mcap"], default="json")
    export.add_argument("-o", "--output", required=True, help="file to write")
    export.set_defaults(func=_export)

    importing = commands.add_parser("import", help="store a session exported as JSON as a new session")
    importing.add_argument("file")
    importing.add_argument("--json", action="store_true")
    importing.set_defaults(func=_import)

    delete = commands.add_parser("delete", help="delete a session and its recordings")
    delete.add_argument("id", type=int)
    delete.add_argument("--yes", action="store_true", help="confirm")
    delete.set_defaults(func=_delete)
