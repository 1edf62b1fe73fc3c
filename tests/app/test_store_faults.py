"""The session store fails under a running robot: the database is locked by another program, or the disk is full.
The server keeps serving and the robot keeps running; the failure is said in the diagnostics; what happened
meanwhile is kept in memory and written once the store takes writes again: nothing is lost."""

from __future__ import annotations

import sqlite3
from pathlib import Path

from sqlalchemy import event, select

from app.sessions.models import CommandRow, EventRow
from tests.app.test_api import plan_state, wait_until


def store_status(client) -> dict:
    groups = client.get("/api/diagnostics").json()["groups"].values()
    return next(s for g in groups for s in g["statuses"] if s["name"] == "links/session_store")


def recorded(client, text: str) -> tuple[list[str], list[str]]:
    rt = client.runtime
    with rt.db() as db:
        commands = db.scalars(select(CommandRow.text).where(CommandRow.session_id == rt.recorder.session_id)).all()
        said = db.scalars(
            select(EventRow.message).where(EventRow.session_id == rt.recorder.session_id, EventRow.kind == "speech/say")
        ).all()
    return list(commands), [m for m in said if text in m]


def test_a_locked_database_is_said_and_what_happened_meanwhile_is_written_once_it_is_free(client, settings) -> None:
    path = Path(settings.database_url.removeprefix("sqlite:///"))
    locker = sqlite3.connect(path, timeout=1.0)
    locker.execute("BEGIN EXCLUSIVE")  # another program holds the database
    try:
        assert client.post("/api/commands", json={"text": "say locked out"}).status_code == 202
        failing = wait_until(lambda: (s := store_status(client))["level_name"] != "OK" and s, timeout=20)
        assert "writes failing" in failing["message"] and "locked" in failing["message"]
        assert client.get("/api/health").status_code == 200
        assert client.post("/api/commands", json={"text": "say still locked"}).status_code == 202
        assert wait_until(lambda: client.runtime.recorder.backlog() > 0, timeout=5)
    finally:
        locker.rollback()
        locker.close()
    assert wait_until(lambda: store_status(client)["level_name"] == "OK", timeout=30)
    # a retry that took its rows before "say still locked" came commits them first: that one goes in the next write
    assert wait_until(lambda: {"say locked out", "say still locked"} <= set(recorded(client, "")[0]), timeout=15)
    assert wait_until(lambda: recorded(client, "still locked")[1], timeout=15)


def test_a_full_disk_is_said_and_nothing_recorded_meanwhile_is_lost(client) -> None:
    engine = client.runtime.engine
    with engine.connect() as connection:
        pages = connection.exec_driver_sql("PRAGMA page_count").scalar()

    def full_disk(dbapi_connection, _record) -> None:  # SQLite's own "disk is full": no page beyond these
        dbapi_connection.execute(f"PRAGMA max_page_count={pages}")

    event.listen(engine, "connect", full_disk)
    engine.dispose()
    try:
        for n in range(3):  # each said before the next comes: a newer command supersedes a plan still running
            text = f"say full disk {n}"
            assert client.post("/api/commands", json={"text": text}).status_code == 202
            wait_until(
                lambda t=text: (p := plan_state(client)) and p["command_text"] == t and p["state"] == "succeeded"
            )
        failing = wait_until(lambda: (s := store_status(client))["level_name"] != "OK" and s, timeout=20)
        assert "disk is full" in failing["message"]
        assert client.get("/api/health").status_code == 200 and client.runtime.worker.is_alive()
    finally:
        event.remove(engine, "connect", full_disk)
        engine.dispose()  # room again
    assert wait_until(lambda: store_status(client)["level_name"] == "OK", timeout=30)
    assert wait_until(lambda: {f"say full disk {n}" for n in range(3)} <= set(recorded(client, "")[0]), timeout=15)
    assert wait_until(lambda: len(recorded(client, "full disk")[1]) == 3, timeout=15)
