"""Shared dependencies and the mapping from robot refusals to HTTP errors."""

from __future__ import annotations

from fastapi import HTTPException, Request

from app.runtime import Runtime
from app.serialize import reply_json
from robot.interface import CommandReply, Refusal

REFUSAL_STATUS = {
    Refusal.ESTOP_LATCHED: 409,
    Refusal.NOT_LATCHED: 409,
    Refusal.NOTHING_TO_REPLAN: 409,
    Refusal.NOTHING_TO_DO: 409,
    Refusal.BUSY: 409,
    Refusal.UNSUPPORTED: 501,
    Refusal.INVALID: 422,
    Refusal.UNAVAILABLE: 503,
}


def runtime(request: Request) -> Runtime:
    return request.app.state.runtime


def raise_if_refused(reply: CommandReply) -> None:
    if not reply.accepted:
        assert reply.refusal is not None
        raise HTTPException(status_code=REFUSAL_STATUS[reply.refusal], detail=reply_json(reply))
