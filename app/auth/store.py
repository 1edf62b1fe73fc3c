"""Users and API tokens in the database: add, list, remove, check a password, issue and check a token."""

from __future__ import annotations

import functools
import re
from dataclasses import dataclass
from datetime import UTC, datetime

from sqlalchemy import func, select
from sqlalchemy.orm import sessionmaker

from app.auth.models import ApiTokenRow, UserRow
from app.auth.roles import Principal, Role
from app.auth.secrets import hash_password, new_token, token_digest, verify_password

NAME_PATTERN = re.compile(r"^[A-Za-z0-9_.-]{1,64}$")


class UserError(ValueError):
    pass


@dataclass(frozen=True)
class UserInfo:
    name: str
    role: Role
    has_password: bool
    tokens: int
    created_at: datetime


class UserStore:
    def __init__(self, db: sessionmaker) -> None:
        self.db = db

    def count(self) -> int:
        with self.db() as s:
            return int(s.scalar(select(func.count()).select_from(UserRow)) or 0)

    def add(self, name: str, role: Role, password: str | None = None) -> None:
        if not NAME_PATTERN.match(name):
            raise UserError("a user name is 1-64 letters, digits, '_', '.' or '-'")
        with self.db() as s, s.begin():
            if s.scalar(select(UserRow).where(UserRow.name == name)) is not None:
                raise UserError(f"user {name!r} exists")
            s.add(
                UserRow(
                    name=name,
                    role=role.value,
                    password_hash=hash_password(password) if password else None,
                    created_at=datetime.now(UTC),
                )
            )

    def set_password(self, name: str, password: str) -> None:
        with self.db() as s, s.begin():
            self._user(s, name).password_hash = hash_password(password)

    def set_role(self, name: str, role: Role) -> None:
        with self.db() as s, s.begin():
            self._user(s, name).role = role.value

    def remove(self, name: str) -> None:
        with self.db() as s, s.begin():
            s.delete(self._user(s, name))

    def list(self) -> list[UserInfo]:
        with self.db() as s:
            counts = dict(s.execute(select(ApiTokenRow.user_id, func.count()).group_by(ApiTokenRow.user_id)).all())
            return [
                UserInfo(u.name, Role(u.role), u.password_hash is not None, counts.get(u.id, 0), u.created_at)
                for u in s.scalars(select(UserRow).order_by(UserRow.name))
            ]

    def check_password(self, name: str, password: str) -> Principal | None:
        with self.db() as s:
            user = s.scalar(select(UserRow).where(UserRow.name == name))
        if user is None or user.password_hash is None:
            verify_password(password, _dummy_hash())  # the same time whether or not the user exists
            return None
        return Principal(user.name, Role(user.role)) if verify_password(password, user.password_hash) else None

    def issue_token(self, name: str, label: str = "api") -> str:
        """A new API token for `name` (shown once: only its digest is kept)."""
        token = new_token()
        with self.db() as s, s.begin():
            user = self._user(s, name)
            s.add(
                ApiTokenRow(user_id=user.id, digest=token_digest(token), label=label[:64], created_at=datetime.now(UTC))
            )
        return token

    def revoke_tokens(self, name: str) -> int:
        with self.db() as s, s.begin():
            user = self._user(s, name)
            rows = s.scalars(select(ApiTokenRow).where(ApiTokenRow.user_id == user.id)).all()
            for row in rows:
                s.delete(row)
            return len(rows)

    def check_token(self, token: str) -> Principal | None:
        with self.db() as s, s.begin():
            row = s.scalar(select(ApiTokenRow).where(ApiTokenRow.digest == token_digest(token)))
            if row is None:
                return None
            user = s.get(UserRow, row.user_id)
            if user is None:
                return None
            row.last_used_at = datetime.now(UTC)
            return Principal(user.name, Role(user.role))

    @staticmethod
    def _user(s, name: str) -> UserRow:  # type: ignore[no-untyped-def]
        user = s.scalar(select(UserRow).where(UserRow.name == name))
        if user is None:
            raise UserError(f"no user {name!r}")
        return user


@functools.cache
def _dummy_hash() -> str:
    return hash_password("not a real password, only for timing")
