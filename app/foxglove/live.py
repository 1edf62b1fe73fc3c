"""The running robot for Foxglove and Lichtblick: foxglove-sdk's WebSocket server (protocol foxglove.sdk.v1) on
loopback, with the channels of an exported session live: the URDF, joint states and /tf at `rate_hz`, camera frames,
the lidar scan, the map and the events as logs.

Where: on loopback only. Beyond this computer it is reached through the app's own port (`/foxglove`,
app.foxglove.proxy), past the app's access control. Clients may not publish (no ClientPublish capability).

Threads: one thread here reads the robot's state board and sensor feed (what the web pages read too, never waiting
on the robot process) and logs to the server, which encodes and sends in its own (Rust) threads; nothing runs on
the web server's event loop.
"""

from __future__ import annotations

import logging
import threading
import time

import foxglove
import mujoco
import numpy as np
from foxglove.websocket import ChannelView, Client, ServerListener, WebSocketServer

from app.foxglove import messages as fm
from app.foxglove.channels import MAP, ROBOT_DESCRIPTION, FoxgloveChannels
from app.foxglove.frames import SceneFrames
from app.sessions.scene import session_scene
from robot.interface import EventSubscription, OccupancyMap, RobotPort
from robot.model import humanoid_v1
from robot.model.urdf import urdf_from_model

log = logging.getLogger(__name__)

LOOPBACK = "127.0.0.1"
DEFAULT_RATE_HZ = 30.0
MAP_PERIOD_S = 1.0  # the map is sent when it changed, at most this often
LATCHED = (ROBOT_DESCRIPTION, MAP, "/scene")  # sent again to each client that subscribes


class _Subscriptions(ServerListener):
    """Notes which latched topics a client just subscribed to (the publishing thread sends them again)."""

    def __init__(self) -> None:
        self.pending: set[str] = set()
        self._lock = threading.Lock()

    def on_subscribe(self, client: Client, channel: ChannelView) -> None:
        if channel.topic in LATCHED:
            with self._lock:
                self.pending.add(channel.topic)

    def take(self) -> set[str]:
        with self._lock:
            pending, self.pending = self.pending, set()
        return pending


class LiveFoxglove:
    """Publishes the robot to Foxglove clients while it runs; `port` is where it listens (on loopback)."""

    def __init__(self, worker: RobotPort, port: int, rate_hz: float = DEFAULT_RATE_HZ) -> None:
        self._worker = worker
        self._requested_port = port
        self.period_s = 1.0 / rate_hz
        self._context = foxglove.Context()
        self._channels = FoxgloveChannels(self._context)
        self._listener = _Subscriptions()
        self._server: WebSocketServer | None = None
        self.stopping = threading.Event()
        self._thread: threading.Thread | None = None
        self.ready = threading.Event()  # the robot's description is being published
        self.published = 0  # joint-state messages so far

    @property
    def port(self) -> int:
        assert self._server is not None, "start() first"
        return self._server.port

    def start(self) -> LiveFoxglove:
        self._server = foxglove.start_server(
            name=f"humanoid mission control ({humanoid_v1.MODEL_NAME})",
            host=LOOPBACK,
            port=self._requested_port,
            capabilities=[],  # no ClientPublish: clients watch, they do not command
            server_listener=self._listener,
            context=self._context,
        )
        self._thread = threading.Thread(target=self._run, name="foxglove-live", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self.stopping.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
        if self._server is not None:
            self._server.stop()

    # ----------------------------------------------------------------------------------------------------------

    def _run(self) -> None:
        try:
            description = self._worker.describe()
            model, _ = session_scene(description.mjcf_xml, description.seed)  # seconds: off the event loop
            urdf = urdf_from_model(model, humanoid_v1.TRUNK_BODY, description.model_name)
            _Publisher(self._worker, self._channels, model, urdf, description.joint_names).loop(self)
        except Exception:  # the live view must never take the server down
            log.exception("the live Foxglove server stopped publishing")

    def latched_requests(self) -> set[str]:
        return self._listener.take()


class _Publisher:
    """What the live thread sends, and what it last sent of each slow sensor."""

    def __init__(
        self,
        worker: RobotPort,
        channels: FoxgloveChannels,
        model: mujoco.MjModel,
        urdf: str,
        joint_names: tuple[str, ...],
    ) -> None:
        self.worker = worker
        self.channels = channels
        self.frames = SceneFrames(model)
        self.urdf = urdf
        self.joint_names = joint_names
        self.joint_qpos = np.array([model.jnt_qposadr[model.joint(n).id] for n in joint_names], dtype=int)
        self.camera_seq = -1
        self.scan_time: float | None = None
        self.map: OccupancyMap | None = None
        self.map_scans = -1
        self.map_sent_at = 0.0

    def loop(self, live: LiveFoxglove) -> None:
        events = self.worker.subscribe()
        try:
            self._send_latched(set(LATCHED))
            live.ready.set()
            next_tick = time.monotonic()
            while not live.stopping.is_set():
                self._send_latched(live.latched_requests())
                self._send_state(live)
                self._send_sensors()
                self._send_events(events)
                next_tick += live.period_s
                delay = next_tick - time.monotonic()
                if delay > 0:
                    live.stopping.wait(delay)
                else:
                    next_tick = time.monotonic()  # late (a busy machine): no burst to catch up
        finally:
            events.close()

    def _send_latched(self, topics: set[str]) -> None:
        now = time.time_ns()
        if ROBOT_DESCRIPTION in topics:
            self.channels.description.log(fm.robot_description(self.urdf), log_time=now)
        if "/scene" in topics:
            self.channels.scene.log(self.frames.world_scene(now), log_time=now)
        if MAP in topics and self.map is not None:
            self.channels.map.log(fm.occupancy_grid(self.map, now), log_time=now)

    def _send_state(self, live: LiveFoxglove) -> None:
        """/tf and the joint states, built only while some client listens (they cost the interpreter's time)."""
        tf, joints = self.channels.tf.has_sinks(), self.channels.joints.has_sinks()
        if not (tf or joints):
            return
        state = self.worker.state()
        now = time.time_ns()
        qpos = np.asarray(state.qpos, dtype=float)
        if tf:
            mocap = np.asarray(state.mocap_positions, dtype=float) if state.mocap_positions else None
            self.channels.tf.log(self.frames.transforms(qpos, mocap, now), log_time=now)
        if joints and qpos.size > int(self.joint_qpos.max(initial=0)):
            self.channels.joints.log(fm.joint_states(self.joint_names, qpos[self.joint_qpos], now), log_time=now)
            live.published += 1

    def _send_sensors(self) -> None:
        feed = self.worker.sensor_feed()
        now = time.time_ns()
        if feed.camera is not None and feed.camera.seq != self.camera_seq:
            self.camera_seq = feed.camera.seq
            if self.channels.camera.has_sinks():
                self.channels.camera.log(fm.compressed_image(feed.camera.jpeg, now), log_time=now)
        if feed.scan is not None and feed.scan.sim_time_s != self.scan_time:
            self.scan_time = feed.scan.sim_time_s
            if self.channels.scan.has_sinks():
                self.channels.scan.log(fm.laser_scan(feed.scan, now), log_time=now)
        map_due = time.monotonic() - self.map_sent_at > MAP_PERIOD_S
        if feed.map is not None and feed.map.scans != self.map_scans and map_due:
            self.map, self.map_scans, self.map_sent_at = feed.map, feed.map.scans, time.monotonic()
            if self.channels.map.has_sinks():
                self.channels.map.log(fm.occupancy_grid(feed.map, now), log_time=now)

    def _send_events(self, events: EventSubscription) -> None:
        while (event := events.get(timeout=0)) is not None:
            now = time.time_ns()
            self.channels.log.log(fm.log(now, int(event.level), event.kind, event.message), log_time=now)
