"""The robot's perception running beside the control loop: a thread that senses at a fixed rate of simulated time.

Each period it takes the latest published state (the simulation's qpos and the robot's estimated trunk pose from
the same tick), has the sensor suite render, detect, scan and map (in a child process), and keeps the
results: the latest camera image and detections, the scan, the occupancy map, the world memory. Consumers wait for
a frame taken after a given instant (`detections_after`), so what they see is never older than what they did.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from robot.interface import (
    CameraImage,
    DetectedObject,
    Level,
    OccupancyMap,
    PerceptionState,
    RobotState,
    ScanView,
    SensorFeed,
)
from robot.model.world import WorldLayout
from robot.perception.detector import Detection
from robot.perception.localisation import Correction
from robot.perception.memory import WorldMemory
from robot.perception.occupancy import OccupancyGrid
from robot.perception.sensor_process import ProcessSensors, SensorError, SensorRunner
from robot.perception.suite import SensorOutput, SensorSnapshot

SENSOR_HZ = 10.0
RATE_WINDOW = 20  # frames over which the rates are measured


def to_detected(d: Detection) -> DetectedObject:
    return DetectedObject(d.label, d.confidence, d.position, d.box, d.distance_m)


def to_map(grid: OccupancyGrid) -> OccupancyMap:
    spec = grid.spec
    # ROS order: row-major with x fastest, i.e. the (nx, ny) array transposed
    data = np.ascontiguousarray(grid.data.T).astype(np.int8).tobytes()
    return OccupancyMap(grid.sim_time_s, spec.resolution, (spec.x0, spec.y0), spec.nx, spec.ny, data, grid.scans)


class _Rate:
    def __init__(self) -> None:
        self._times: deque[float] = deque(maxlen=RATE_WINDOW)

    def tick(self, t: float) -> None:
        self._times.append(t)

    @property
    def hz(self) -> float:
        if len(self._times) < 2 or self._times[-1] <= self._times[0]:
            return 0.0
        return (len(self._times) - 1) / (self._times[-1] - self._times[0])


class PerceptionService:
    """`sensors`: makes what senses (default: the simulated suite in its own process; on the real robot, its
    drivers), called on the service's thread."""

    def __init__(
        self,
        layout: WorldLayout,
        latest_state: Callable[[], RobotState],
        publish: Callable[..., object],
        hz: float = SENSOR_HZ,
        sensors: Callable[[], SensorRunner] | None = None,
    ) -> None:
        self.layout = layout
        self._sensors = sensors or (lambda: ProcessSensors(layout))
        self.memory = WorldMemory(layout)
        self._latest_state = latest_state
        self._publish = publish
        self._period = 1.0 / hz
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._cond = threading.Condition()
        self._state = PerceptionState("starting")
        self._feed = SensorFeed()
        self._camera_rate = _Rate()
        self._lidar_rate = _Rate()
        self._clear_map = False
        self._next_time = 0.0  # sim time of the next sensing instant
        self._silenced: set[str] = set()  # injected faults: sensors whose data no longer arrives ("camera", "lidar")

    def start(self) -> None:
        if self._thread is None:
            self._stop.clear()
            self._thread = threading.Thread(target=self._run, name="robot-perception", daemon=True)
            self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        with self._cond:
            self._cond.notify_all()
        if self._thread is not None:
            self._thread.join(timeout=10.0)
            self._thread = None

    def state(self) -> PerceptionState:
        """The latest perception state (built when it changes: the control loop reads it every tick)."""
        with self._cond:
            return self._state

    def forget_objects(self) -> None:
        """Clear the world memory (the objects were put back where the world starts them)."""
        self.memory.clear()
        self._set(known_objects=())

    def localise(self, x: float, y: float, yaw: float) -> tuple[float, float, float]:
        """An odometry pose in the map frame (scan matching's latest correction applied)."""
        with self._cond:
            cx, cy, cyaw = self._state.correction
        return Correction(cx, cy, cyaw).apply(x, y, yaw)

    def feed(self) -> SensorFeed:
        with self._cond:
            return self._feed

    def wait_until_served(self, sim_time_s: float, timeout_s: float = 30.0) -> None:
        """Headless runs: block the simulation while a sensing instant is a whole period overdue (or the sensors
        are still starting), so sensors run at their rate in simulated time however fast the simulation goes."""
        deadline = time.monotonic() + timeout_s
        with self._cond:
            while not self._stop.is_set():
                starting = self._state.status == "starting"
                if not starting and (self._state.status != "ok" or sim_time_s < self._next_time + self._period):
                    return
                if time.monotonic() >= deadline:
                    break
                self._cond.wait(0.05)
            else:
                return
        # sensing hangs: say so and let the robot go on without it, rather than stall the simulation for good
        self._fail(f"the sensors did not answer for {timeout_s:.0f} s: perception stopped")

    def silence(self, sensor: str, silent: bool = True) -> None:
        """Simulate a sensor whose data stops arriving (a cable out, a driver hung): "camera" or "lidar"."""
        if sensor not in ("camera", "lidar"):
            raise ValueError(f"no sensor {sensor!r}: camera or lidar")
        (self._silenced.add if silent else self._silenced.discard)(sensor)

    def clear_map(self) -> None:
        """Forget the map (the robot was moved by hand, or the world changed); the next scan starts a new one."""
        self._clear_map = True

    def detections_after(self, sim_time_s: float, timeout_s: float = 10.0) -> tuple[DetectedObject, ...]:
        """The detections of the first camera frame taken at or after `sim_time_s` (blocks up to `timeout_s`)."""
        deadline = time.monotonic() + timeout_s
        with self._cond:
            while self._state.frame_sim_s < sim_time_s or self._state.frame_seq == 0:
                if self._state.status.startswith("error"):
                    raise SensorError(self._state.status)
                remaining = deadline - time.monotonic()
                if remaining <= 0 or self._stop.is_set():
                    raise SensorError(f"no camera frame after t={sim_time_s:.2f} s within {timeout_s:.0f} s")
                self._cond.wait(min(remaining, 0.1))
            return self._state.detections

    # ---------------------------------------------------------------------------------------------------------

    def _run(self) -> None:
        try:
            # its own process in headless runs too: on two cores, sensing then runs beside the control loop instead
            # of taking turns with it for the interpreter lock (a headless pick's wall/sim time: 0.87 -> 0.68)
            runner: SensorRunner = self._sensors()
        except Exception as exc:
            self._fail(f"the sensors could not start: {exc}")
            return
        self._set(status="ok")
        try:
            while not self._stop.is_set():
                state = self._latest_state()
                loco = state.locomotion
                if state.sim_time_s < self._next_time or loco is None or len(loco.estimated_trunk) != 7:
                    self._stop.wait(0.001)
                    continue
                with self._cond:
                    self._next_time = max(self._next_time + self._period, state.sim_time_s)
                    self._cond.notify_all()
                if self._clear_map:
                    self._clear_map = False
                    runner.clear_map()
                trunk = np.asarray(loco.estimated_trunk, dtype=float)
                # a fallen robot's pose estimate means nothing: no mapping until it stands again
                snapshot = SensorSnapshot(
                    state.sim_time_s,
                    np.asarray(state.qpos, dtype=float),
                    trunk[:3],
                    trunk[3:],
                    lidar=not state.fallen,
                    mocap_positions=np.asarray(state.mocap_positions, dtype=float),
                )
                self._absorb(runner.process(snapshot))
        except SensorError as exc:
            self._fail(str(exc))
        except Exception as exc:  # perception must never take the robot down
            self._fail(f"perception failed: {exc!r}")
        finally:
            runner.close()

    def _absorb(self, out: SensorOutput) -> None:
        if self._silenced:
            out = replace(
                out,
                camera=None if "camera" in self._silenced else out.camera,
                scan=None if "lidar" in self._silenced else out.scan,
                grid=None if "lidar" in self._silenced else out.grid,
            )
        feed = self._feed
        updates: dict[str, object] = {}
        if out.camera is not None:
            frame = out.camera
            detections = tuple(to_detected(d) for d in frame.detections)
            self._camera_rate.tick(frame.sim_time_s)
            feed = replace(
                feed, camera=CameraImage(frame.seq, frame.sim_time_s, frame.width, frame.height, frame.jpeg, detections)
            )
            changed = self.memory.observe(detections, frame.sim_time_s)
            updates["known_objects"] = self.memory.snapshot()
            for known in changed:
                where = f" on the {known.place}" if known.place and known.place != "floor" else ""
                x, y, z = known.position
                self._publish(
                    "perception/object_seen",
                    f"saw the {known.name} at ({x:.2f}, {y:.2f}, {z:.2f}){where}",
                    name=known.name,
                    position=list(known.position),
                    place=known.place,
                )
            updates.update(
                frame_seq=frame.seq,
                frame_sim_s=frame.sim_time_s,
                detections=detections,
                frame_ms=sum(out.timings_ms.get(k, 0.0) for k in ("render_ms", "detect_ms", "encode_ms")),
                camera_hz=round(self._camera_rate.hz, 2),
            )
        if out.scan is not None:
            scan = out.scan.scan
            self._lidar_rate.tick(scan.sim_time_s)
            view = ScanView(
                scan.sim_time_s,
                out.scan.pose,
                scan.height_m,
                scan.angle_min,
                scan.angle_increment,
                scan.range_max,
                tuple(float(r) for r in scan.ranges),
            )
            feed = replace(feed, scan=view)
            updates["lidar_hz"] = round(self._lidar_rate.hz, 2)
        if out.grid is not None:
            feed = replace(feed, map=to_map(out.grid))
            updates["map_scans"] = out.grid.scans
        updates["correction"] = (out.correction.x, out.correction.y, out.correction.yaw)
        with self._cond:
            self._feed = feed
            self._state = replace(self._state, **updates)
            self._cond.notify_all()

    def _set(self, **changes: object) -> None:
        with self._cond:
            self._state = replace(self._state, **changes)
            self._cond.notify_all()

    def _fail(self, message: str) -> None:
        self._set(status=f"error: {message}")
        self._publish("perception/error", message, Level.ERROR)
