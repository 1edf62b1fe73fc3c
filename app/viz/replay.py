"""3D replay of stored sessions: a viser server of its own (like the live mirror, behind a gate) that shows the
recorded robot and objects moving as they did, with play, pause, seek and speed, and plots of key signals around
the replay's time (joint targets against positions, the centre of mass, the battery, the control tick time).

The sessions page drives it through the API (a click on a timeline entry seeks to that moment) and its own
controls drive it from the 3D view; both act on the one replay this server shows, which every viewer of it sees.
"""

from __future__ import annotations

import contextlib
import logging
import threading
import time
from dataclasses import dataclass

import mujoco
import numpy as np
import viser
from mjviser.scene import ViserMujocoScene
from sqlalchemy.orm import sessionmaker
from viser import uplot

from app.sessions.models import SessionRow
from app.sessions.queries import load_telemetry, session_detail
from app.sessions.scene import session_scene
from app.viz.mirror import LIGHT, MirrorProfile, mirror_model
from robot.telemetry import TelemetryLayout

log = logging.getLogger(__name__)

FRAME_HZ = 30.0  # scene updates per second while playing
PLOT_WINDOW_S = 20.0  # the plots show this much before the replay's time, and a little after
GUI_EVERY_S = 0.2  # the controls' time and "now" while playing (each update is a message to every viewer)
PLOT_EVERY_S = 1.0  # while playing; a seek redraws them at once
SPEEDS = ("0.25", "0.5", "1", "2", "4")
SECONDS = {"x": uplot.Scale(time=False)}  # the x axis is simulated seconds, not a date


class ReplayError(ValueError):
    """A replay request that cannot be served (no such session, nothing recorded to replay)."""


@dataclass(frozen=True)
class ReplayStatus:
    session_id: int | None
    sim_time_s: float
    start_s: float
    end_s: float
    playing: bool
    speed: float
    samples: int
    now: str  # the timeline entry in force at the replay's time
    frames: int  # pictures sent to the viewers so far

    def as_dict(self) -> dict:
        return self.__dict__.copy()


class ReplayTrack:
    """A session's telemetry as arrays, looked up by simulated time."""

    def __init__(self, layout: TelemetryLayout, rows: np.ndarray) -> None:
        if len(rows) == 0:
            raise ReplayError("this session recorded no motion to replay")
        self.layout = layout
        order = np.argsort(rows[:, 0], kind="stable")
        self.rows = rows[order]
        self.times = self.rows[:, 0]
        self.slices = layout.slices()

    @property
    def start(self) -> float:
        return float(self.times[0])

    @property
    def end(self) -> float:
        return float(self.times[-1])

    def index_at(self, t: float) -> int:
        """The last sample taken at or before `t` (the first one before the start)."""
        return max(0, int(np.searchsorted(self.times, t, side="right")) - 1)

    def field(self, name: str, index: int) -> np.ndarray | None:
        s = self.slices.get(name)
        return None if s is None else self.rows[index, s]

    def window(
        self, name: str, t0: float, t1: float, column: int = 0, max_points: int = 600
    ) -> tuple[np.ndarray, np.ndarray]:
        s = self.slices.get(name)
        i0, i1 = np.searchsorted(self.times, [t0, t1])
        if s is None or i1 <= i0:
            return np.zeros(0), np.zeros(0)
        stride = max(1, (i1 - i0) // max_points)
        return self.times[i0:i1:stride], self.rows[i0:i1:stride, s.start + column]


class SessionReplay:
    """The replay's viser server, its controls and plots, and the thread that plays it."""

    def __init__(self, factory: sessionmaker, profile: MirrorProfile = LIGHT) -> None:
        self._factory = factory
        self._profile = profile
        self._lock = threading.RLock()
        # on loopback: browsers come through its gate (`app.viz.scene_gate`), which checks their login
        self.server = viser.ViserServer(host="127.0.0.1", port=0, label="humanoid session replay", verbose=False)
        self.server.initial_camera.position = (-3.2, -2.8, 3.0)
        self.server.initial_camera.look_at = (0.0, 0.0, 0.2)
        self.server.scene.configure_environment_map(hdri=None, environment_intensity=0.0)
        self.server.scene.configure_default_lights(enabled=True, cast_shadow=False)
        self._session_id: int | None = None
        self._track: ReplayTrack | None = None
        self._timeline: list[dict] = []
        self._scene: ViserMujocoScene | None = None
        self._model: mujoco.MjModel | None = None
        self._data: mujoco.MjData | None = None
        self._scene_key: tuple | None = None
        self._t = 0.0
        self._playing = False
        self._speed = 1.0
        self._last_plot = -np.inf
        self._build_gui()
        self.frames = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="session-replay", daemon=True)
        self._thread.start()

    @property
    def upstream_port(self) -> int:
        return int(self.server.get_port())

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2.0)
        self.server.stop()

    # ----------------------------------------------------------------------------------------------------------
    # what the API calls

    def load(self, session_id: int, sim_time_s: float | None = None) -> ReplayStatus:
        """Show `session_id` (loading it unless it is shown already), at `sim_time_s` or its start, paused."""
        with self._lock:
            if session_id != self._session_id:
                self._load(session_id)
            assert self._track is not None
            self._playing = False
            self._seek(self._track.start if sim_time_s is None else sim_time_s)
            return self.status()

    def seek(self, sim_time_s: float) -> ReplayStatus:
        with self._lock:
            self._require_loaded()
            self._seek(sim_time_s)
            return self.status()

    def play(self, speed: float | None = None) -> ReplayStatus:
        with self._lock:
            track = self._require_loaded()
            if speed is not None:
                self._speed = float(speed)
            if self._t >= track.end:
                self._seek(track.start)
            self._playing = True
            self._sync_gui()
            return self.status()

    def pause(self) -> ReplayStatus:
        with self._lock:
            self._playing = False
            self._sync_gui()
            return self.status()

    def status(self) -> ReplayStatus:
        with self._lock:
            track = self._track
            return ReplayStatus(
                session_id=self._session_id,
                sim_time_s=round(self._t, 3),
                start_s=track.start if track else 0.0,
                end_s=track.end if track else 0.0,
                playing=self._playing,
                speed=self._speed,
                samples=len(track.rows) if track else 0,
                now=self._now_text(),
                frames=self.frames,
            )

    # ----------------------------------------------------------------------------------------------------------

    def _require_loaded(self) -> ReplayTrack:
        if self._track is None:
            raise ReplayError("no session is loaded in the replay")
        return self._track

    def _load(self, session_id: int) -> None:
        with self._factory() as db:
            row = db.get(SessionRow, session_id)
            if row is None:
                raise ReplayError(f"no session {session_id}")
            layout, rows = load_telemetry(db, session_id)
            if layout is None:
                raise ReplayError(f"session {session_id} recorded no motion to replay")
            track = ReplayTrack(layout, rows)
            detail = session_detail(db, session_id) or {}
            key = (row.scene_mjcf or "", row.seed)
        if key != self._scene_key:
            _, xml = session_scene(row.scene_mjcf, row.seed)
            model = mirror_model(xml, self._profile)
            if self._scene is not None:
                self.server.scene.reset()
                self.server.scene.configure_default_lights(enabled=True, cast_shadow=False)
            self._scene = ViserMujocoScene(self.server, model, num_envs=1)
            self._scene.camera_tracking_enabled = False
            self._model, self._data = model, mujoco.MjData(model)
            self._scene_key = key
        self._session_id, self._track = session_id, track
        self._timeline = [i for i in detail.get("timeline", []) if i.get("sim_time_s") is not None]
        what = f"({detail.get('kind', '?')}, seed {detail.get('seed', '?')})"
        self._title.content = (
            f"**Session {session_id}** {what}: {track.end - track.start:.1f} s, {len(track.rows)} samples"
        )
        self._time.min, self._time.max = track.start, max(track.end, track.start + 0.01)
        self._joint.options = list(layout.joint_names) or ["(none recorded)"]
        self._last_plot = -np.inf

    def _seek(self, t: float) -> None:
        track = self._require_loaded()
        self._t = float(min(max(t, track.start), track.end))
        self._last_plot = -np.inf
        self._show()
        self._sync_gui()

    def _show(self) -> None:
        track, model, data, scene = self._track, self._model, self._data, self._scene
        if track is None or model is None or data is None or scene is None:
            return
        i = track.index_at(self._t)
        qpos = track.field("qpos", i)
        if qpos is not None:
            n = min(qpos.size, model.nq)
            data.qpos[:n] = np.nan_to_num(qpos[:n])
        mocap = track.field("mocap_pos", i)
        if mocap is not None and mocap.size == data.mocap_pos.size and np.all(np.isfinite(mocap)):
            data.mocap_pos[:] = mocap.reshape(data.mocap_pos.shape)
        mujoco.mj_kinematics(model, data)
        scene.update_from_mjdata(data)
        if abs(self._t - self._last_plot) >= PLOT_EVERY_S:
            self._update_plots()
        self.server.flush()
        self.frames += 1

    def _now_text(self) -> str:
        current = [i for i in self._timeline if i["sim_time_s"] <= self._t + 1e-6]
        return current[-1]["text"] if current else ""

    # ----------------------------------------------------------------------------------------------------------
    # the 3D view's own controls and plots

    def _build_gui(self) -> None:
        gui = self.server.gui
        self._title = gui.add_markdown("No session loaded: pick one on the sessions page.")
        self._play = gui.add_button("Play")
        self._time = gui.add_slider("Time (s)", min=0.0, max=1.0, step=0.01, initial_value=0.0)
        self._speed_in = gui.add_dropdown("Speed", options=SPEEDS, initial_value="1")
        self._now = gui.add_markdown("")
        self._joint = gui.add_dropdown("Joint", options=["(none recorded)"])
        self._plot_joint = self._add_plot(
            "joint target vs position (rad)", (("target", "#d04040"), ("position", "#3060d0"))
        )
        self._plot_com = self._add_plot("centre of mass (m)", (("x", "#d04040"), ("y", "#30a030"), ("z", "#3060d0")))
        self._plot_battery = self._add_plot("battery voltage (V)", (("battery V", "#c08000"),))
        self._plot_tick = self._add_plot("control tick (ms)", (("tick ms", "#606060"),))
        self._syncing = False

        @self._play.on_click
        def _(_event: viser.GuiEvent) -> None:
            with contextlib.suppress(ReplayError):  # nothing loaded yet: nothing to play
                self.pause() if self._playing else self.play()

        @self._time.on_update
        def _(_event: viser.GuiEvent) -> None:
            if self._syncing or self._track is None:
                return
            with self._lock:
                self._seek(float(self._time.value))

        @self._speed_in.on_update
        def _(_event: viser.GuiEvent) -> None:
            self._speed = float(self._speed_in.value)

        @self._joint.on_update
        def _(_event: viser.GuiEvent) -> None:
            with self._lock:
                self._last_plot = -np.inf
                self._update_plots()

    def _add_plot(self, title: str, lines: tuple[tuple[str, str], ...]) -> viser.GuiUplotHandle:
        empty = np.zeros(1)
        series = (
            uplot.Series(label="t (s)"),
            *(uplot.Series(label=label, stroke=colour, width=1.5) for label, colour in lines),
        )
        return self.server.gui.add_uplot(
            data=(empty,) * (len(lines) + 1), series=series, title=title, aspect=2.0, scales=SECONDS
        )

    def _sync_gui(self) -> None:
        """Show the replay's state in its own controls (without the slider's update seeking again)."""
        self._syncing = True
        try:
            self._time.value = round(self._t, 2)
            self._play.label = "Pause" if self._playing else "Play"
            self._speed_in.value = next((s for s in SPEEDS if float(s) == self._speed), self._speed_in.value)
            self._now.content = f"t = {self._t:.2f} s — {self._now_text()}"
        finally:
            self._syncing = False

    def _update_plots(self) -> None:
        track = self._track
        if track is None:
            return
        self._last_plot = self._t
        t0, t1 = self._t - PLOT_WINDOW_S, self._t + 0.1 * PLOT_WINDOW_S
        names = track.layout.joint_names
        joint = names.index(self._joint.value) if self._joint.value in names else 0
        t, target = track.window("joint_target", t0, t1, joint)
        _, position = track.window("joint_position", t0, t1, joint)
        if t.size:
            self._plot_joint.data = (t, target, position)
        t, cx = track.window("com", t0, t1, 0)
        if t.size:
            self._plot_com.data = (t, cx, track.window("com", t0, t1, 1)[1], track.window("com", t0, t1, 2)[1])
        t, volts = track.window("battery_v", t0, t1)
        if t.size:
            self._plot_battery.data = (t, volts)
        t, tick = track.window("tick_ms", t0, t1)
        if t.size:
            self._plot_tick.data = (t, tick)

    def _run(self) -> None:
        period = 1.0 / FRAME_HZ
        last: float | None = None
        last_gui = -np.inf
        next_frame = time.perf_counter()
        while not self._stop.wait(max(0.0, next_frame - time.perf_counter())):
            next_frame = max(next_frame + period, time.perf_counter())  # a frame's work is part of its period
            with self._lock:  # (loading a session holds it for seconds: that time is not replay time)
                now = time.perf_counter()
                if not self._playing or self._track is None:
                    last = None
                    continue
                elapsed = 0.0 if last is None else now - last
                last = now
                try:
                    self._t = min(self._t + elapsed * self._speed, self._track.end)
                    if self._t >= self._track.end:
                        self._playing = False
                    self._show()
                    if not self._playing or now - last_gui >= GUI_EVERY_S:
                        self._sync_gui()
                        last_gui = now
                except Exception:  # a viewer glitch must not end the replay thread
                    log.exception("replay frame failed")
