"""The sessions API as the sessions page and scripts use it: filters, delete, telemetry, export and import."""

from __future__ import annotations

import json

from tests.app.test_api import plan_state, wait_until


def _finished_session(client) -> int:
    """The live session of this server, after a command ran and an e-stop came and went."""
    client.post("/api/commands", json={"text": "say recorded"})
    wait_until(lambda: (p := plan_state(client)) and p["state"] == "succeeded")
    client.post("/api/estop")
    client.post("/api/estop/reset")
    sid = client.get("/api/health").json()["session_id"]
    wait_until(lambda: client.get(f"/api/sessions/{sid}").json()["telemetry"]["samples"] > 30)
    return sid


def test_the_live_session_is_listed_filtered_and_cannot_be_deleted(client) -> None:
    sid = _finished_session(client)
    listing = client.get("/api/sessions").json()
    assert listing["live_session_id"] == sid and listing["items"][0]["outcome"] == "running"
    assert [s["id"] for s in client.get("/api/sessions?had_estop=true&q=RECORDED").json()["items"]] == [sid]
    assert client.get("/api/sessions?had_estop=false").json()["total"] == 0
    assert client.get("/api/sessions?outcome=running").json()["total"] == 1
    assert client.get("/api/sessions?outcome=exploded").status_code == 422
    assert client.get("/api/sessions?from=not-a-date").status_code == 422
    future = "2100-01-01T00:00:00Z"
    assert client.get(f"/api/sessions?from={future}").json()["total"] == 0
    refused = client.delete(f"/api/sessions/{sid}")
    assert refused.status_code == 409 and "being recorded" in refused.json()["detail"]
    assert client.delete("/api/sessions/999999").status_code == 404


def test_telemetry_signals_are_served_for_plots(client) -> None:
    sid = _finished_session(client)
    series = client.get(f"/api/sessions/{sid}/telemetry?fields=battery_v,joint_target,tick_ms&max_points=50").json()
    assert 10 <= len(series["sim_time_s"]) <= 50 and len(series["joint_target"]) == 24
    assert all(20 < v < 25.3 for v in series["battery_v"][0] if v is not None)
    bad = client.get(f"/api/sessions/{sid}/telemetry?fields=warp_drive")
    assert bad.status_code == 422 and "warp_drive" in bad.json()["detail"]


def test_a_session_exported_as_json_imports_as_a_new_one_and_can_then_be_deleted(client) -> None:
    sid = _finished_session(client)
    exported = client.get(f"/api/sessions/{sid}/export?format=json")
    assert exported.status_code == 200 and "attachment" in exported.headers["content-disposition"]
    doc = exported.json()
    assert doc["session"]["id"] == sid and doc["commands"][0]["text"] == "say recorded" and doc["telemetry"]
    imported = client.post("/api/sessions/import", content=exported.content)
    assert imported.status_code == 201
    new_id = imported.json()["session_id"]
    copy = client.get(f"/api/sessions/{new_id}").json()
    assert copy["kind"] == "import" and copy["commands"][0]["text"] == "say recorded"
    assert copy["estop_count"] == 1 and copy["telemetry"]["samples"] == len(doc["telemetry"])
    assert client.get("/api/sessions?kind=import").json()["total"] == 1
    bad = client.post("/api/sessions/import", content=json.dumps({"format": "zip"}))
    assert bad.status_code == 422 and "not a session export" in bad.json()["detail"]
    assert client.delete(f"/api/sessions/{new_id}").json() == {"deleted": new_id}
    assert client.get(f"/api/sessions/{new_id}").status_code == 404


def test_mcap_export_downloads(client) -> None:
    sid = _finished_session(client)
    exported = client.get(f"/api/sessions/{sid}/export?format=mcap")
    assert exported.status_code == 200 and exported.content[:8] == b"\x89MCAP0\r\n"
    assert client.get(f"/api/sessions/{sid}/export?format=zip").status_code == 422


def test_without_3d_views_the_replay_says_so(client) -> None:
    response = client.post("/api/replay", json={"session_id": 1})
    assert response.status_code == 503 and "disabled" in response.json()["detail"]


def test_an_id_no_database_row_can_have_is_refused_as_invalid_not_a_server_error(client) -> None:
    # (found by the API fuzz test: an id past SQL's 64-bit integers overflowed in the database driver: a 500)
    for path in ("/api/sessions/399804205910799876096", "/api/sessions/0", "/api/sessions?offset=99999999999999999999"):
        assert client.get(path).status_code == 422, path
    assert client.get("/api/sessions/1/transcripts/99999999999999999999/audio.wav").status_code == 422
