"""Everything a running server holds: the robot port, the mirrors, the DB and the session being recorded."""

from __future__ import annotations

import logging
from dataclasses import dataclass

from sqlalchemy import Engine
from sqlalchemy.orm import sessionmaker

from app.mirror import FULL, LIGHT, SceneMirror
from app.sessions.db import make_engine, make_session_factory, upgrade_to_head
from app.sessions.recorder import SessionRecorder
from app.settings import Settings
from robot.interface import RobotPort
from robot.model.world import generate_world
from robot.process import WorkerProcess
from robot.worker import RobotWorker

log = logging.getLogger(__name__)


@dataclass
class Runtime:
    settings: Settings
    worker: RobotPort
    engine: Engine
    db: sessionmaker
    recorder: SessionRecorder
    mirrors: dict[str, SceneMirror]  # by profile name: "full" and "light"

    @staticmethod
    def start(settings: Settings, worker: RobotPort | None = None) -> Runtime:
        """Migrate the DB, start the robot worker (in its own process unless given one), the recorder, the mirror."""
        upgrade_to_head(settings.database_url)
        engine = make_engine(settings.database_url)
        db = make_session_factory(engine)
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
                )
            )
        worker.start()
        recorder = SessionRecorder(db, worker, kind="serve", seed=settings.seed, backend=settings.backend,
                                   sample_hz=settings.state_sample_hz, audio_dir=settings.audio_dir)  # fmt: skip
        mirrors = {}
        if settings.enable_mirror:
            for profile, viser_port in ((FULL, settings.viser_port), (LIGHT, settings.viser_light_port)):
                mirrors[profile.name] = SceneMirror(worker, settings.viser_host, viser_port, settings.mirror_hz,
                                                    profile=profile, shadows=settings.mirror_shadows)  # fmt: skip
                mirrors[profile.name].start()
        return Runtime(settings, worker, engine, db, recorder, mirrors)

    def stop(self) -> None:
        for mirror in self.mirrors.values():
            mirror.stop()
        self.worker.stop()
        self.recorder.close(outcome=None)
        self.engine.dispose()
