"""Everything a running server holds: the robot port, the mirrors, the DB and the session being recorded."""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from sqlalchemy import Engine
from sqlalchemy.orm import sessionmaker

from app.auth.access import AccessControl
from app.auth.control import ControlLock
from app.auth.scene_tokens import SceneTokens
from app.auth.store import UserStore
from app.foxglove.live import LiveFoxglove
from app.sessions.db import make_engine, make_session_factory, upgrade_to_head
from app.sessions.maintenance import apply_retention, close_interrupted_sessions
from app.sessions.recorder import SessionRecorder
from app.settings import Settings
from app.supervisor import WorkerSupervisor
from app.viz.mirror_process import MirrorProcess, RemoteMirror
from app.viz.scene_clicks import SceneClicks
from app.viz.scene_gate import SceneGate
from robot.interface import RobotPort
from robot.model.world import generate_world
from robot.process import HardwareSpec, WorkerProcess
from robot.worker import RobotWorker

if TYPE_CHECKING:  # (the 3D views' modules import viser, mjviser and trimesh: seconds, only when they are on)
    from app.viz.mirror import SceneMirror
    from app.viz.replay import SessionReplay

log = logging.getLogger(__name__)


def _maintain(db: sessionmaker, settings: Settings, live_session_id: int) -> None:
    """Every few minutes while serving: close sessions other servers left open, apply the retention settings."""
    close_interrupted_sessions(db)
    apply_retention(
        db,
        settings.audio_dir,
        settings.session_retention_days,
        settings.session_retention_count,
        keep={live_session_id},
    )


def _open_recorder(db: sessionmaker, worker: RobotPort, settings: Settings) -> SessionRecorder:
    return SessionRecorder(
        db,
        worker,
        kind="serve",
        seed=settings.seed,
        backend=settings.backend,
        audio_dir=settings.audio_dir,
        camera_hz=settings.record_camera_hz,
        camera_width=settings.record_camera_width,
        scan_hz=settings.record_scan_hz,
        map_period_s=settings.record_map_period_s,
        maintenance=lambda session_id: _maintain(db, settings, session_id),
    )


@dataclass
class Runtime:
    settings: Settings
    worker: RobotPort
    engine: Engine
    db: sessionmaker
    recorder: SessionRecorder
    mirrors: dict[str, SceneMirror | RemoteMirror]  # by profile name: "full" and "light"
    replay: SessionReplay | None = None  # the stored sessions' 3D replay (with the mirrors)
    browser_clients: int = 0  # pages connected to /ws now
    access: AccessControl | None = None  # None: as "off" (tests that build a Runtime by hand)
    control: ControlLock = field(default_factory=ControlLock)  # the one operator in control
    supervisor: WorkerSupervisor | None = None  # restarts a robot process that died
    mirror_process: MirrorProcess | None = None  # the 3D mirrors, when they run in their own process
    scene_tokens: SceneTokens = field(default_factory=SceneTokens)  # what opens the 3D views (their gates check)
    gates: dict[str, SceneGate] = field(default_factory=dict)  # the 3D views' gates run in this process
    foxglove: LiveFoxglove | None = None  # the live Foxglove server (humanoid serve --foxglove-port N)

    @staticmethod
    def start(settings: Settings, worker: RobotPort | None = None) -> Runtime:
        """Migrate the DB, start the robot worker (in its own process unless given one), the recorder, the mirror."""
        upgrade_to_head(settings.database_url)
        engine = make_engine(settings.database_url)
        db = make_session_factory(engine)
        access = AccessControl(settings.auth, UserStore(db), settings.host)
        access.check_exposure()  # before anything starts: no robot behind an open door
        close_interrupted_sessions(db)
        if worker is None and settings.backend == "dynamixel":
            spec = HardwareSpec(settings.hardware_config(), settings.deadman_s)
            if settings.worker_process:  # its loop must not share the interpreter lock with the web server
                worker = WorkerProcess(
                    settings.seed, diagnostics=settings.diagnostics, disk_path=settings.data_dir, hardware=spec
                )
            else:
                from robot.hardware.worker import HardwareWorker

                worker = HardwareWorker(
                    spec.config,
                    generate_world(settings.seed),
                    diagnostics=settings.diagnostics,
                    disk_path=settings.data_dir,
                    deadman_s=spec.deadman_s,
                    walk=True,
                )
        if worker is None:
            worker = (
                WorkerProcess(
                    settings.seed,
                    control_hz=settings.control_hz,
                    perception=settings.perception,
                    planning=settings.planner_config(),
                    max_auto_replans=settings.max_auto_replans,
                    approve_plans=settings.approve_plans,
                    voice=settings.voice_config(),
                    diagnostics=settings.diagnostics,
                    disk_path=settings.data_dir,
                )
                if settings.worker_process
                else RobotWorker(
                    generate_world(settings.seed),
                    realtime=True,
                    control_hz=settings.control_hz,
                    perception=settings.perception,
                    planning=settings.planner_config(),
                    max_auto_replans=settings.max_auto_replans,
                    approve_plans=settings.approve_plans,
                    voice=settings.voice_config(),
                    diagnostics=settings.diagnostics,
                    disk_path=settings.data_dir,
                )
            )
        worker.start()
        recorder = _open_recorder(db, worker, settings)
        control, tokens, clicks = ControlLock(), SceneTokens(), SceneClicks()
        mirrors: dict[str, SceneMirror | RemoteMirror] = {}
        gates: dict[str, SceneGate] = {}
        mirror_process = None
        host = settings.scene_host()
        ports = {"full": settings.viser_port, "light": settings.viser_light_port}
        tls = settings.tls_files()
        if settings.enable_mirror and isinstance(worker, WorkerProcess):  # (the robot's messages feed it directly)
            mirror_process = MirrorProcess(
                worker, host, ports, settings.mirror_hz, settings.mirror_shadows, tokens, clicks.on_click, tls
            )
            mirror_process.start()
            mirrors.update(mirror_process.mirrors)
        elif settings.enable_mirror:
            from app.viz.mirror import open_views

            in_process, gates = open_views(
                worker,
                host,
                ports,
                settings.mirror_hz,
                settings.mirror_shadows,
                tokens.verify,
                clicks.on_click,
                tls.server_context() if tls else None,
            )
            mirrors.update(in_process)
        replay = None
        if settings.enable_mirror:
            from app.viz.replay import SessionReplay

            replay = SessionReplay(db)
            gates["replay"] = SceneGate(
                "replay",
                host,
                settings.replay_port,
                replay.upstream_port,
                tokens.verify,
                tls=tls.server_context() if tls else None,
            )
            gates["replay"].start()
        foxglove = LiveFoxglove(worker, settings.foxglove_port).start() if settings.foxglove_port is not None else None
        rt = Runtime(
            settings,
            worker,
            engine,
            db,
            recorder,
            mirrors,
            replay,
            access=access,
            control=control,
            mirror_process=mirror_process,
            scene_tokens=tokens,
            gates=gates,
            foxglove=foxglove,
        )
        clicks.runtime = rt
        if settings.supervise_worker and isinstance(worker, WorkerProcess):
            rt.supervisor = WorkerSupervisor(worker, on_death=rt._session_crashed, on_restart=rt._new_session)
            rt.supervisor.start()
        return rt

    def scene_port(self, view: str) -> int | None:
        """The port browsers open a 3D view on ("full", "light", "replay"); None when it is off."""
        if view in self.gates:
            return self.gates[view].port
        mirror = self.mirrors.get(view)
        return mirror.port if isinstance(mirror, RemoteMirror) else None

    def end_scene_login(self, login: str) -> None:
        """A login ended: the 3D views stop admitting its token and disconnect its viewers."""
        self.scene_tokens.revoke(login)
        for gate in self.gates.values():
            gate.revoke(login)
        if self.mirror_process is not None:
            self.mirror_process.revoke(login)

    def _session_crashed(self, why: str) -> None:
        """The robot process died: its session ends with all it had kept, as "crashed"."""
        self.recorder.close(outcome="crashed", summary={"cause": f"the robot process died ({why})"})

    def _new_session(self) -> None:
        """The restarted robot's life is a new session (its clock starts again)."""
        self.recorder = _open_recorder(self.db, self.worker, self.settings)

    def stop(self) -> None:
        if self.supervisor is not None:
            self.supervisor.stop()
        for gate in self.gates.values():
            gate.stop()
        for mirror in self.mirrors.values():
            mirror.stop()
        if self.mirror_process is not None:
            self.mirror_process.stop()
        if self.replay is not None:
            self.replay.stop()
        if self.foxglove is not None:
            self.foxglove.stop()
        self.worker.stop()
        self.recorder.close()
        self.engine.dispose()
