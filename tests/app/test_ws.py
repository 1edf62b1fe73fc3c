from __future__ import annotations

import time

import pytest

from tests.app.test_api import wait_until


def receive_until(ws, predicate, limit: int = 200):
    for _ in range(limit):
        message = ws.receive_json()
        if predicate(message):
            return message
    raise AssertionError("expected message not received")


def test_socket_streams_state_and_takes_the_estop(client) -> None:
    with client.websocket_connect("/ws") as ws:
        hello = ws.receive_json()
        assert hello["type"] == "hello" and hello["session_id"] >= 1
        state = receive_until(ws, lambda m: m["type"] == "state")
        assert state["state"]["mode"] == "idle"

        ws.send_json({"type": "estop", "client_time_s": time.time()})
        ack = receive_until(ws, lambda m: m["type"] == "estop_ack")
        assert ack["accepted"]
        latched = receive_until(ws, lambda m: m["type"] == "event" and m["event"]["kind"] == "estop/latched")
        assert latched["event"]["data"]["source"] == "browser"
        assert 0 <= latched["event"]["data"]["latency_ms"] < 1000
        receive_until(ws, lambda m: m["type"] == "state" and m["state"]["estop_latched"])

        ws.send_json({"type": "estop_release"})
        assert receive_until(ws, lambda m: m["type"] == "estop_release_ack")["accepted"]


def test_socket_answers_bad_messages_without_closing(client) -> None:
    with client.websocket_connect("/ws") as ws:
        ws.receive_json()
        ws.send_text("not json")
        assert receive_until(ws, lambda m: m["type"] == "error")["message"].startswith("expected a JSON object")
        ws.send_json({"type": "dance"})
        assert "unknown message type" in receive_until(ws, lambda m: m["type"] == "error")["message"]
        ws.send_text("x" * 5000)
        assert "larger than" in receive_until(ws, lambda m: m["type"] == "error")["message"]
        ws.send_json({"type": "ping", "t": 1})
        assert receive_until(ws, lambda m: m["type"] == "pong")["t"] == 1


def test_socket_teleop_drives_and_closing_the_socket_stops_the_robot(client) -> None:
    worker = client.runtime.worker
    with client.websocket_connect("/ws") as ws:
        ws.receive_json()
        ws.send_json({"type": "teleop", "vx": "fast"})
        assert "finite number" in receive_until(ws, lambda m: m["type"] == "teleop_ack")["message"]
        ws.send_json({"type": "teleop", "vx": 250.0})
        assert "refused" in receive_until(ws, lambda m: m["type"] == "teleop_ack")["message"]
        for _ in range(8):
            ws.send_json({"type": "teleop", "vx": 0.1, "vy": 0.0, "yaw_rate": 0.0})
            time.sleep(0.1)
        receive_until(ws, lambda m: m["type"] == "state" and m["state"]["mode"] == "teleop")
    # the browser went away while driving: stopped at once, not only by the deadman
    # (looked for among the events, not as the latest: the walk's end follows it a couple of seconds later)
    stop = wait_until(lambda: next((e for e in worker.recent_events() if e.kind == "teleop/stop"), None))
    assert stop.data["source"] == "browser-disconnect"
    assert worker.wait_for(lambda s: s.mode.value == "idle", 30.0)


def test_the_estop_has_a_second_socket_of_its_own(client) -> None:
    """The page sends each press on both sockets: whichever arrives first latches, the other changes nothing."""
    worker = client.runtime.worker
    with client.websocket_connect("/ws") as ws, client.websocket_connect("/ws/stop") as backup:
        ws.receive_json()
        backup.send_json({"type": "teleop", "vx": 0.1})
        assert "e-stops and pings only" in backup.receive_json()["message"]  # it cannot drive
        backup.send_json({"type": "ping", "t": 7})
        assert backup.receive_json() == {"type": "pong", "t": 7, "server_time_s": pytest.approx(time.time(), abs=60)}
        pressed = time.time()
        backup.send_json({"type": "estop", "client_time_s": pressed})
        ws.send_json({"type": "estop", "client_time_s": pressed})
        assert backup.receive_json()["accepted"] and receive_until(ws, lambda m: m["type"] == "estop_ack")["accepted"]
        receive_until(ws, lambda m: m["type"] == "state" and m["state"]["estop_latched"])
        latched = [e for e in worker.recent_events() if e.kind == "estop/latched"]
        assert len(latched) == 1 and latched[0].data["source"] in ("browser", "browser-backup")
