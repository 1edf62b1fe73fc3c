"""`humanoid users add | list | passwd | role | remove | token | revoke-tokens`: who may use the console (the
database named by DATABASE_URL; a running server sees changes within a second)."""

from __future__ import annotations

import argparse
import getpass
import json
import sys

from app.settings import Settings


def _store(settings: Settings):  # type: ignore[no-untyped-def]
    from app.auth.store import UserStore
    from app.sessions.db import make_engine, make_session_factory, upgrade_to_head

    upgrade_to_head(settings.database_url)
    return UserStore(make_session_factory(make_engine(settings.database_url)))


def _password(args: argparse.Namespace) -> str:
    """From stdin with --password-stdin (scripts), else asked twice on the terminal."""
    if args.password_stdin:
        return sys.stdin.readline().rstrip("\n")
    first = getpass.getpass("password: ")
    if first != getpass.getpass("again: "):
        raise ValueError("the two passwords differ")
    return first


def _run(args: argparse.Namespace, settings: Settings) -> int:
    from app.auth.roles import Role
    from app.auth.secrets import WeakPassword
    from app.auth.store import UserError

    store = _store(settings)
    try:
        if args.users_command == "add":
            password = None if args.token_only else _password(args)
            store.add(args.name, Role(args.role), password)
            print(f"added {args.name} ({args.role})" + (": API tokens only" if args.token_only else ""))
        elif args.users_command == "passwd":
            store.set_password(args.name, _password(args))
            print(f"password of {args.name} changed (their browser logins stay until they expire or log out)")
        elif args.users_command == "role":
            store.set_role(args.name, Role(args.role))
            print(f"{args.name} is now {args.role}")
        elif args.users_command == "remove":
            store.remove(args.name)
            print(f"removed {args.name} and their tokens")
        elif args.users_command == "token":
            token = store.issue_token(args.name, args.label)
            print(
                token
                if args.quiet
                else f"token for {args.name} (shown once; send it as 'Authorization: Bearer <token>'):\n{token}"
            )
        elif args.users_command == "revoke-tokens":
            print(f"revoked {store.revoke_tokens(args.name)} tokens of {args.name}")
        else:  # list
            users = store.list()
            if args.json:
                print(
                    json.dumps(
                        [
                            {
                                "name": u.name,
                                "role": u.role.value,
                                "password": u.has_password,
                                "tokens": u.tokens,
                                "created_at": u.created_at.isoformat(),
                            }
                            for u in users
                        ],
                        indent=2,
                    )
                )
            else:
                for u in users:
                    print(
                        f"{u.name:<20} {u.role.value:<9} {'password' if u.has_password else 'no password':<12} "
                        f"{u.tokens} tokens"
                    )
                if not users:
                    print("no users: access control is off (the app serves only 127.0.0.1)")
    except (UserError, WeakPassword, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    return 0


def add_users_parser(sub: argparse._SubParsersAction) -> None:
    users = sub.add_parser("users", help="who may watch (viewer) and drive (operator) through the web app")
    commands = users.add_subparsers(dest="users_command", required=True)
    add = commands.add_parser("add", help="add a user (asks for a password)")
    add.add_argument("name")
    add.add_argument("--role", choices=["viewer", "operator"], required=True)
    add.add_argument("--token-only", action="store_true", help="no password: API tokens only (scripts)")
    passwd = commands.add_parser("passwd", help="change a user's password")
    passwd.add_argument("name")
    role = commands.add_parser("role", help="change a user's role")
    role.add_argument("name")
    role.add_argument("role", choices=["viewer", "operator"])
    remove = commands.add_parser("remove", help="remove a user and their tokens")
    remove.add_argument("name")
    token = commands.add_parser("token", help="issue an API token (printed once)")
    token.add_argument("name")
    token.add_argument("--label", default="api")
    token.add_argument("--quiet", action="store_true", help="print the token alone")
    revoke = commands.add_parser("revoke-tokens", help="revoke every API token of a user")
    revoke.add_argument("name")
    listing = commands.add_parser("list", help="list users")
    listing.add_argument("--json", action="store_true")
    for parser in (add, passwd):
        parser.add_argument("--password-stdin", action="store_true", help="read the password from stdin")
    for parser in (add, passwd, role, remove, token, revoke, listing):
        parser.set_defaults(func=_run)
