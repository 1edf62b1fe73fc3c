"""The two roles: a viewer watches and may press the e-stop (anyone who sees the robot may stop it); an operator
also commands, drives, releases the e-stop, replans and deletes sessions."""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum


class Role(StrEnum):
    VIEWER = "viewer"
    OPERATOR = "operator"

    def allows(self, needed: Role) -> bool:
        return needed == Role.VIEWER or self == Role.OPERATOR


@dataclass(frozen=True)
class Principal:
    name: str
    role: Role


# Who everyone is when access control is off (the app serves only this computer: its user operates).
LOCAL_OPERATOR = Principal("local", Role.OPERATOR)
