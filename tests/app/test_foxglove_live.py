"""The live Foxglove server (`humanoid serve --foxglove-port N`): a client speaking the Foxglove WebSocket protocol
gets the channels advertised and the robot's joint states, cannot publish, and through the app's `/foxglove`
gets in only with an API token when access control is on."""

from __future__ import annotations

import asyncio
import base64
import json
import struct
import time
from collections.abc import Iterator

import pytest
import websockets
from fastapi.testclient import TestClient
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from starlette.websockets import WebSocketDisconnect

from app.auth.roles import Role
from app.foxglove import channels as topics
from app.runtime import Runtime
from app.web.main import create_app
from tests.app.test_access import PASSWORD, user_store

LIVE_TOPICS = {
    topics.ROBOT_DESCRIPTION,
    topics.TF,
    topics.JOINT_STATES,
    topics.CAMERA,
    topics.SCAN,
    topics.MAP,
    topics.LOG,
}
MESSAGE_DATA = 0x01  # binary opcode of a message on a subscription


@pytest.fixture
def live(settings, make_worker) -> Iterator[Runtime]:
    runtime = Runtime.start(settings.model_copy(update={"foxglove_port": 0}), worker=make_worker(realtime=True))
    assert runtime.foxglove is not None and runtime.foxglove.ready.wait(60.0)
    yield runtime
    runtime.stop()


def _decoder(channel: dict):
    files = descriptor_pb2.FileDescriptorSet.FromString(base64.b64decode(channel["schema"]))
    pool = descriptor_pool.DescriptorPool()
    for file in files.file:
        pool.Add(file)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(channel["schemaName"]))


async def _session(port: int, seconds: float) -> dict:
    """Connect, read the advertised channels, subscribe to the joint states and the robot description, count what
    arrives for `seconds`."""
    async with websockets.connect(f"ws://127.0.0.1:{port}", subprotocols=["foxglove.sdk.v1"], max_size=None) as ws:
        assert ws.subprotocol == "foxglove.sdk.v1"
        info = json.loads(await ws.recv())
        assert info["op"] == "serverInfo"
        channels: dict[str, dict] = {}
        while not channels.keys() >= LIVE_TOPICS:
            message = json.loads(await asyncio.wait_for(ws.recv(), 10.0))
            if message["op"] == "advertise":
                channels.update({c["topic"]: c for c in message["channels"]})
        joints, description = channels[topics.JOINT_STATES], channels[topics.ROBOT_DESCRIPTION]
        await ws.send(
            json.dumps(
                {
                    "op": "subscribe",
                    "subscriptions": [{"id": 1, "channelId": joints["id"]}, {"id": 2, "channelId": description["id"]}],
                }
            )
        )
        decode = _decoder(joints)
        arrivals: list[float] = []
        first = None
        urdf = None
        started = time.monotonic()
        while time.monotonic() - started < seconds:
            data = await asyncio.wait_for(ws.recv(), 10.0)
            if not isinstance(data, bytes) or data[0] != MESSAGE_DATA:
                continue
            subscription = struct.unpack_from("<I", data, 1)[0]
            payload = data[1 + 4 + 8 :]
            if subscription == 2:
                urdf = json.loads(payload)["data"]
            else:
                arrivals.append(time.monotonic())
                first = first or decode.FromString(payload)
        # a client may not publish: the server has no ClientPublish capability and says so
        await ws.send(
            json.dumps(
                {"op": "advertise", "channels": [{"id": 1, "topic": "/cmd", "encoding": "json", "schemaName": "x"}]}
            )
        )
        refusal = None
        while refusal is None:
            reply = await asyncio.wait_for(ws.recv(), 10.0)
            if isinstance(reply, str) and json.loads(reply)["op"] == "status":
                refusal = json.loads(reply)
    return {"info": info, "channels": channels, "arrivals": arrivals, "first": first, "urdf": urdf, "refusal": refusal}


def test_a_foxglove_client_gets_the_channels_and_the_joint_states(live: Runtime) -> None:
    got = asyncio.run(_session(live.foxglove.port, seconds=4.0))
    assert "clientPublish" not in got["info"]["capabilities"]
    schemas = {t: c["schemaName"] for t, c in got["channels"].items()}
    assert schemas[topics.JOINT_STATES] == "foxglove.JointStates" and schemas[topics.TF] == "foxglove.FrameTransforms"
    assert schemas[topics.SCAN] == "foxglove.LaserScan" and schemas[topics.MAP] == "foxglove.Grid"
    assert schemas[topics.CAMERA] == "foxglove.CompressedImage" and schemas[topics.LOG] == "foxglove.Log"
    assert schemas[topics.ROBOT_DESCRIPTION] == "std_msgs/String"
    assert got["urdf"] is not None and got["urdf"].startswith("<?xml") and "<robot" in got["urdf"]
    assert {j.name for j in got["first"].joints} >= {"r_knee", "l_grip", "head_pan"}
    arrivals = got["arrivals"]
    assert len(arrivals) >= 2 and arrivals[-1] - arrivals[0] > 1.0  # they keep arriving
    rate = (len(arrivals) - 1) / (arrivals[-1] - arrivals[0])
    print(f"\nlive joint states: {len(arrivals)} messages, {rate:.1f} Hz")  # measured, not asserted (a busy machine)
    assert got["refusal"]["level"] == 2 and "clientPublish" in got["refusal"]["message"]


@pytest.fixture
def secured_live(settings, make_worker) -> Iterator[tuple[TestClient, str]]:
    store = user_store(settings)
    store.add("vic", Role.VIEWER, PASSWORD)
    token = store.issue_token("vic")
    runtime = Runtime.start(settings.model_copy(update={"foxglove_port": 0}), worker=make_worker(realtime=True))
    assert runtime.foxglove.ready.wait(60.0)
    with TestClient(create_app(settings, runtime=runtime)) as client:
        yield client, token
    runtime.stop()


def test_with_access_control_only_a_token_gets_through_the_apps_port(secured_live) -> None:
    client, token = secured_live
    for url in ("/foxglove", "/foxglove?token=not-a-token"):
        with pytest.raises(WebSocketDisconnect), client.websocket_connect(url, subprotocols=["foxglove.sdk.v1"]) as ws:
            ws.receive_text()
    # the login cookie is no proof here (another site's page could ride on it)
    assert client.post("/api/auth/login", json={"name": "vic", "password": PASSWORD}).status_code == 200
    with (
        pytest.raises(WebSocketDisconnect),
        client.websocket_connect("/foxglove", subprotocols=["foxglove.sdk.v1"]) as ws,
    ):
        ws.receive_text()
    client.cookies.clear()
    with client.websocket_connect(
        f"/foxglove?token={token}",
        subprotocols=["foxglove.websocket.v1"],
        headers={"Origin": "https://app.foxglove.dev"},
    ) as ws:
        assert json.loads(ws.receive_text())["op"] == "serverInfo"
        advertised: set[str] = set()
        while not advertised >= LIVE_TOPICS:
            message = json.loads(ws.receive_text())
            advertised |= {c["topic"] for c in message.get("channels", [])}
