"""Shared fixtures. Building the MuJoCo scene costs seconds, so the model for seed 0 is built once per run."""

from __future__ import annotations

import ctypes
import ctypes.util
import gc
import os

# llama.cpp's OpenMP threads (the LLM tests) sleep while they wait instead of spinning, which on a busy machine
# made a reply 20x slower; read when the library loads, so before any test imports it
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

from collections.abc import Iterator
from pathlib import Path

import mujoco
import pytest
from fastapi.testclient import TestClient

from app.runtime import Runtime
from app.settings import Settings
from app.web.main import create_app
from robot.diagnostics.thresholds import Thresholds
from robot.model.scene import build_scene
from robot.model.world import WorldLayout, generate_world
from robot.sim.backend import MujocoSimBackend
from robot.worker import RobotWorker
from tests.support import file_order


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption(
        "--record-file-durations",
        action="store_true",
        help=f"write each test file's seconds to {file_order.DURATIONS_FILE.name} (the order `make test` runs them)",
    )


def pytest_configure(config: pytest.Config) -> None:
    if config.getoption("record_file_durations"):
        config.pluginmanager.register(file_order.DurationRecorder(), "file-durations")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    items[:] = file_order.longest_files_first(items, file_order.load_durations())


def _give_back_freed_memory() -> None:
    """glibc keeps what a process frees (each thread's arena, the top of the heap) for later: building a model with
    its meshes frees ~0.4 GB it keeps. Tests build dozens in one process, and two such processes (`pytest -n 2`)
    once grew to 8 GB each and ran a 23 GB machine out of memory."""
    gc.collect()
    libc = ctypes.util.find_library("c")
    if libc and "glibc" in (os.confstr("CS_GNU_LIBC_VERSION") or "").lower():
        ctypes.CDLL(libc).malloc_trim(0)


@pytest.fixture(scope="module", autouse=True)
def _freed_memory_returned_after_each_module() -> Iterator[None]:
    yield
    _give_back_freed_memory()


@pytest.fixture(scope="session")
def layout() -> WorldLayout:
    return generate_world(0)


@pytest.fixture(scope="session")
def scene_model(layout: WorldLayout) -> mujoco.MjModel:
    return build_scene(layout, drawn=False)  # as the robot's physics builds it


@pytest.fixture
def make_worker(layout: WorldLayout, scene_model: mujoco.MjModel) -> Iterator:
    """Factory of started workers on a fresh simulation of seed 0; all are stopped at teardown. Perception (the
    camera, lidar and map, a few seconds to start) is off unless a test asks for it."""
    workers: list[RobotWorker] = []

    def make(realtime: bool = True, perception: bool = False, **kwargs) -> RobotWorker:
        # A loaded test machine can pause an in-process worker's loop longer than the robot's watchdog allows (and
        # a safe stop would then refuse the test's commands): tests of the watchdog pass their own thresholds.
        kwargs.setdefault("diagnostics", Thresholds(control_stale_s=3.0))
        worker = RobotWorker(
            layout, backend=MujocoSimBackend(layout, scene_model), realtime=realtime, perception=perception, **kwargs
        )
        worker.start()
        workers.append(worker)
        return worker

    yield make
    for worker in workers:
        worker.stop()


@pytest.fixture
def settings(tmp_path: Path) -> Settings:
    # the grammar recogniser unless a test asks for whisper: its transcripts are the commands' own words, and fast
    return Settings(
        database_url=f"sqlite:///{tmp_path / 'test.db'}",
        enable_mirror=False,
        seed=0,
        audio_dir=str(tmp_path / "audio"),
        asr_engine="pocketsphinx",
    )


@pytest.fixture
def client(settings: Settings, make_worker) -> Iterator[TestClient]:
    """The real app on a real (real-time) worker and a temporary SQLite DB; no 3D mirror."""
    runtime = Runtime.start(settings, worker=make_worker(realtime=True))
    with TestClient(create_app(settings, runtime=runtime)) as test_client:
        test_client.runtime = runtime  # type: ignore[attr-defined]
        yield test_client
    runtime.stop()


@pytest.fixture
def served(settings: Settings) -> Iterator[TestClient]:
    """The app as `humanoid serve` runs it: the robot in its own process (its threads at real-time priority, its
    own interpreter lock), supervised, with the robot's own diagnostics thresholds. Perception off: faster."""
    runtime = Runtime.start(settings.model_copy(update={"perception": False}))
    with TestClient(create_app(settings, runtime=runtime)) as test_client:
        test_client.runtime = runtime  # type: ignore[attr-defined]
        yield test_client
    runtime.stop()
