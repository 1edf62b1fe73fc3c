"""The robot's diagnostics, wired: which readings feed which check, and the monitor that samples them.

`RobotDiagnostics` is what the worker holds; it knows the worker only through the callables it is given."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from robot.control.stats import LoopStats
from robot.diagnostics.checks import control_status, gait_status, power_status, sensor_statuses, servo_statuses
from robot.diagnostics.compute import ComputeProbe
from robot.diagnostics.links import PlannerLink
from robot.diagnostics.monitor import DiagnosticsMonitor
from robot.diagnostics.thresholds import Thresholds
from robot.hardware.xm430 import ServoReadings
from robot.interface import (
    DiagnosticArray,
    DiagnosticStatus,
    Level,
    LocomotionState,
    PerceptionState,
    PowerState,
    SensorFeed,
)
from robot.planning.config import PlannerConfig


@dataclass
class RobotReadings:
    """Where each reading comes from (callables into the worker, read from the monitor's thread)."""

    joint_names: Sequence[str]
    stats: LoopStats
    servos: Callable[[], ServoReadings]
    power: Callable[[], PowerState | None]
    battery_cells: int
    perception: Callable[[], PerceptionState | None]
    sensor_feed: Callable[[], SensorFeed]
    sim_time: Callable[[], float]
    imu_stamp: Callable[[], float | None]
    voice: Callable[[], Any]  # the RobotVoice, or None when voice is not set up
    sensor_hz: float
    has_imu: bool = True
    lost_servos: Callable[[], tuple[str, ...]] = lambda: ()
    hardware_ids: Sequence[str] | None = None  # e.g. "XM430-W350 id 13"
    devices: Callable[[], list[DiagnosticStatus]] = lambda: []  # a real robot's own sensor drivers
    locomotion: Callable[[], LocomotionState | None] = lambda: None  # the legs' state, on a robot that walks
    perceives: tuple[str, ...] = ("camera", "lidar")  # the sensors its perception has (a real robot: those fitted)


class RobotDiagnostics:
    def __init__(
        self,
        readings: RobotReadings,
        limits: Thresholds,
        realtime: bool,
        disk_path: str,
        planner: PlannerConfig | None,
        planner_name: str,
        publish: Callable[..., object],
        safe_stop: Callable[[str], None],
        period_s: float = 1.0,
    ) -> None:
        self.readings = readings
        self.limits = limits
        self.realtime = realtime
        self.compute = ComputeProbe(disk_path, limits)
        self.planner_link = PlannerLink(planner, limits.link_check_period_s, limits.link_timeout_s) if planner else None
        self.planner_name = planner_name
        self._misses = (time.monotonic(), readings.stats.deadline_misses)
        self._late_plans = (time.monotonic(), 0, 0.0)
        self.monitor = DiagnosticsMonitor(
            [self.compute.statuses, self._control, self._servos, self._power, self._sensors, self._links],
            publish,
            safe_stop,
            readings.sim_time,
            period_s,
            watchdog=self._watchdog if realtime else None,
        )

    def start(self) -> None:
        if self.planner_link is not None:
            self.planner_link.start()
        self.monitor.start()

    def stop(self) -> None:
        self.monitor.stop()
        if self.planner_link is not None:
            self.planner_link.stop()

    def latest(self) -> DiagnosticArray | None:
        return self.monitor.latest()

    def unsafe(self) -> list[DiagnosticStatus]:
        return self.monitor.unsafe()

    # sources ---------------------------------------------------------------------------------------------------

    def _tick_age(self) -> float:
        return time.perf_counter() - self.readings.stats.last_tick_end

    def _watchdog(self) -> DiagnosticStatus | None:
        age = self._tick_age()
        if age <= self.limits.control_stale_s:
            return None
        return control_status(self.readings.stats.snapshot(), age, 0.0, True, self.limits)

    def _control(self) -> list[DiagnosticStatus]:
        stats = self.readings.stats
        now, misses = time.monotonic(), stats.deadline_misses
        then, before = self._misses
        self._misses = (now, misses)
        rate = (misses - before) / (now - then) if now > then else 0.0
        statuses = [control_status(stats.snapshot(), self._tick_age(), rate, self.realtime, self.limits)]
        legs = self.readings.locomotion()
        if self.realtime and legs is not None:  # headless, the walk waits for its plans
            then, plans, late_s = self._late_plans
            self._late_plans = (now, legs.late_plans, legs.late_plans_s)
            statuses.append(gait_status(legs.late_plans - plans, legs.late_plans_s - late_s, now - then, self.limits))
        return statuses

    def _servos(self) -> list[DiagnosticStatus]:
        r = self.readings
        return servo_statuses(r.joint_names, r.servos(), self.limits, r.hardware_ids, r.lost_servos())

    def _power(self) -> list[DiagnosticStatus]:
        if self.readings.battery_cells == 0:  # no battery monitoring on this robot
            return []
        return [power_status(self.readings.power(), self.readings.battery_cells, self.limits)]

    def _sensors(self) -> list[DiagnosticStatus]:
        r = self.readings
        sim_time = r.sim_time()
        stamp = r.imu_stamp()
        feed = r.sensor_feed()
        statuses = sensor_statuses(
            r.perception(),
            sim_time,
            feed.camera.sim_time_s if feed.camera else None,
            feed.scan.sim_time_s if feed.scan else None,
            max(0.0, sim_time - stamp) if stamp is not None else 0.0,
            r.sensor_hz,
            self.limits,
        )
        wanted = {f"sensors/{name}" for name in r.perceives} | ({"sensors/imu"} if r.has_imu else set())
        return [s for s in statuses if s.name in wanted] + r.devices()

    def _links(self) -> list[DiagnosticStatus]:
        out = [
            self.planner_link.status()
            if self.planner_link is not None
            else DiagnosticStatus("links/planner", Level.OK, self.planner_name)
        ]
        voice = self.readings.voice()
        if voice is not None:
            if voice.listening:
                out.append(
                    DiagnosticStatus(
                        "links/robot_asr", Level.OK, f"{voice.microphone_status}: listening", voice.config.engine
                    )
                )
            elif voice.microphone is not None:
                out.append(
                    DiagnosticStatus(
                        "links/robot_asr",
                        Level.ERROR,
                        "the recogniser is not running; the robot's microphone is unheard",
                        voice.config.engine,
                    )
                )
            else:
                out.append(
                    DiagnosticStatus(
                        "links/robot_asr",
                        Level.OK,
                        f"{voice.microphone_status}; voice commands work through the page",
                        voice.config.engine,
                    )
                )
        return out
