"""A server killed mid-task (kill -9) loses at most the last second of samples, and no command, plan or event:
after a restart its session is closed as interrupted, with everything recorded up to the kill."""

from __future__ import annotations

import time

import httpx
import pytest

from harness.server import ServerProcess

pytestmark = pytest.mark.slow


def _wait(predicate, timeout_s: float, what: str):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(0.1)
    raise AssertionError(f"not within {timeout_s} s: {what}")


def test_a_killed_server_leaves_its_session_intact_up_to_the_last_second(tmp_path) -> None:
    first = ServerProcess(tmp_path, views=False).__enter__()
    try:
        session_id = first.get("/api/health")["session_id"]
        reply = first.post("/api/commands", json={"text": "go to the charging dock"})
        assert reply.status_code == 202
        _wait(
            lambda: (p := first.get("/api/state")["plan"]) and p["steps"][0]["state"] == "running",
            30.0,
            "the walk starts",
        )
        time.sleep(4.0)  # walking
        last_event_seq = max(e["seq"] for e in first.get("/api/events"))
        # the recorder writes what the robot publishes as it comes (a busy machine delays it a little): everything
        # published so far reaches the disk, and what is on disk survives the kill
        _wait(
            lambda: last_event_seq in {e["seq"] for e in first.get(f"/api/sessions/{session_id}")["events"]},
            30.0,
            "the events published so far are recorded",
        )
        killed_at = time.time()
        first.kill()
    finally:
        first.__exit__(None, None, None)

    with ServerProcess(tmp_path, views=False) as second:
        assert second.get("/api/health")["session_id"] != session_id
        crashed = second.get(f"/api/sessions/{session_id}")
        assert crashed["outcome"] == "interrupted" and crashed["ended_at"] is not None
        assert [c["text"] for c in crashed["commands"]] == ["go to the charging dock"]
        assert crashed["plans"] and crashed["plans"][0]["plan"]["steps"][0]["action"] == "navigate_to"
        recorded_seqs = {e["seq"] for e in crashed["events"]}
        # every event recorded before the kill is still there, and none before it is missing
        assert set(range(1, last_event_seq + 1)) - recorded_seqs == set()
        walls = httpx.get(
            f"{second.url}/api/sessions/{session_id}/telemetry",
            params={"fields": "wall_time_s", "max_points": 20000},
            timeout=30,
        ).json()
        last_sample = walls["wall_time_s"][0][-1]
        assert killed_at - last_sample <= 1.0, f"lost {killed_at - last_sample:.2f} s of samples"
        sims = walls["sim_time_s"]
        assert len(sims) > 30 * (sims[-1] - sims[0]) * 0.9  # 33 Hz, no holes
