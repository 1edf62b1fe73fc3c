"""The real robot's body: XM430s on a Dynamixel bus, driven at a fixed rate by the same core as the simulation.

What it does on hardware today: torque on and off (off at start-up until the operator turns it on), postures
(stand, crouch) at a capped joint speed, the e-stop (the controlled-stop posture, a slow crouch, then torque off),
the same stop when the control loop stalls past the servos' bus watchdog (which has already stopped them where
they were) or the browser's deadman lapses, every goal clamped to the joint's limits, servos that stop answering
or latch a hardware error surfaced in diagnostics (and stopping the robot), and the measured pose for the 3D
mirror. With its senses (`HardwareSenses`: the OpenCR's IMU and the FSR foot modules read in the same tick as the
servos, or a BNO055 on its own port) the measurements carry the trunk's orientation, angular velocity and the
feet's forces, a tilt past the fall threshold is a fall, and a sense lost with torque on brings the robot down
by the controlled stop. What it lacks (no IMU, no foot sensors, no legs' controller) the core refuses with
`lacks`, the reason.
"""

from __future__ import annotations

import contextlib
import math
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from robot.bodies.hardware_senses import HardwareSenses
from robot.control.stats import BusTickStats, LoopStats
from robot.core.body import BodyLinks, BodySnapshot, CommandHandler
from robot.core.measurements import FALL_TILT_DEG, Measurements
from robot.core.safety import LatchWords
from robot.diagnostics.robot_sources import RobotReadings
from robot.hardware.bus import BusError, BusReading, DynamixelBus
from robot.hardware.config import HardwareConfig
from robot.hardware.xm430 import LOAD_AVERAGE_S, STALL_CURRENT_A, ServoReadings
from robot.interface import (
    CommandReply,
    DiagnosticStatus,
    EStop,
    Level,
    OperatorHeartbeat,
    PerceptionState,
    Refusal,
    SensorFeed,
    SetTorque,
)
from robot.model import humanoid_v1
from robot.model.world import WorldLayout
from robot.perception.driver_sensors import DriverSensors
from robot.perception.service import SENSOR_HZ, PerceptionService
from robot.sim.backend import MujocoSimBackend

ESTOP_TORQUE_OFF_AFTER_S = 3.0  # the controlled stop's crouch has this long before torque goes off
DEADMAN_S = 1.5  # torque on needs an operator heartbeat at least this often (the page sends one every 250 ms)
CONTROLLED_STOP_SPEED_RAD_S = 0.6
BUS_WARN_SHARE = 0.8  # the bus's round trip at p99 past this share of the control period is said
UPRIGHT_TILT_DEG = 15.0  # a fallen robot stood up again by hand may move again below this tilt
NOT_ON_HARDWARE = "needs the IMU, cameras and foot sensors, which are not on the servo bus: simulation only for now"
HARDWARE_WORDS = LatchWords(
    latched="e-stop latched: crouching, then torque off",
    already_latched="e-stop latched: crouching, then torque off",
    released="torque stays off",
    release_reply="e-stop released; turn torque on to move again",
)


class HardwareBody:
    """`estop_torque_off_s`: how long the controlled stop's crouch has before torque goes off; `deadman_s`: 0
    turns the operator deadman off (a script that keeps torque on by itself, at its risk)."""

    kind = "hardware"
    resettable = False
    latch_words = HARDWARE_WORDS
    physics_hz = 0.0
    stop_by_tick = True
    telemetry = None

    def __init__(
        self,
        config: HardwareConfig,
        layout: WorldLayout,
        bus: DynamixelBus | None = None,
        estop_torque_off_s: float = ESTOP_TORQUE_OFF_AFTER_S,
        deadman_s: float = DEADMAN_S,
        sensing: HardwareSenses | None = None,
        walking_enabled: bool = False,
        started_at: float | None = None,
    ) -> None:
        """`sensing`: the IMU, feet, camera and lidar (None: the servos alone); `walking_enabled`: the robot is given
        a legs' controller (without one the core refuses walking and plans); `started_at`: the monotonic time its
        clock counts from (the one its sensors stamp with; default: now)."""
        self.config = config
        self.layout = layout
        self.bus = bus or DynamixelBus(config)
        self.bus_lock = threading.Lock()  # the control loop holds it each tick; a stop from outside takes it
        self.estop_torque_off_s = estop_torque_off_s
        self.deadman_s = deadman_s
        self.joint_names = config.joint_names
        self.dt = 1.0 / config.control_hz
        self.scene = MujocoSimBackend(layout)  # never stepped: the model the mirror draws the measured pose in
        self._stand = np.array([humanoid_v1.stand_posture()[n] for n in self.joint_names])
        self._crouch = np.array([humanoid_v1.crouch_posture()[n] for n in self.joint_names])
        self._links: BodyLinks | None = None
        self._lock = threading.Lock()
        self._torque_requests: list[SetTorque] = []
        self._heartbeat_s = time.monotonic()
        self._started_at = time.monotonic() if started_at is None else started_at
        self._torque = False
        self._estop_since: float | None = None
        self._stop_applied_at: float | None = None  # wall clock; until the stop's first goals are on the bus
        self._stop_written_at: float | None = None  # wall clock: the stop's goals written by `hold_now`
        self._reading: BusReading | None = None
        self._positions = np.zeros(len(self.joint_names))
        self._targets = self._positions.copy()
        self._last_tick_s: float | None = None
        n = len(self.joint_names)
        base = layout.robot_start
        yaw = base[2] if len(base) > 2 else 0.0
        self._base = (float(base[0]), float(base[1]), 0.0)
        self._yaw = float(yaw)
        self.sensing = sensing or HardwareSenses(None, None, self._yaw, self.now)
        self.perception: PerceptionService | None = None
        self.senses = self.sensing.senses
        self.lacks = self.sensing.lacks(walking_enabled)
        self._walking_enabled = walking_enabled
        self.tick_split = BusTickStats()  # each tick's time on the bus, and the rest
        self._bus_s = 0.0
        self._tick_started = 0.0  # when this tick's read began (perf_counter)
        self._trunk_estimate: Callable[[], tuple[np.ndarray, np.ndarray]] | None = None
        self._zero_velocities = np.zeros(n)
        self._load_pct = np.zeros(n)

    def bind(self, links: BodyLinks) -> None:
        self._links = links
        links.latch.on_release(self._released)
        camera, lidar = self.sensing.camera, self.sensing.lidar
        # their frames are detected, mapped and localised as the simulation's, at the legs' estimate of the trunk
        if self._walking_enabled and (camera is not None or lidar is not None):
            layout = self.layout
            self.perception = PerceptionService(
                layout, links.latest_state, links.publish, sensors=lambda: DriverSensors(layout, camera, lidar)
            )

    @property
    def links(self) -> BodyLinks:
        assert self._links is not None, "bind the body to a robot first"
        return self._links

    @property
    def connected(self) -> bool:
        return self._reading is not None

    @property
    def torque_on(self) -> bool:
        return self._torque

    def now(self) -> float:
        """Seconds since the body was made (the real robot's clock: its state and events are stamped with it)."""
        return time.monotonic() - self._started_at

    @property
    def tick_guard(self) -> threading.Lock:
        return self.bus_lock

    def stand_posture(self) -> np.ndarray:
        return self._stand.copy()

    def crouch_posture(self) -> np.ndarray:
        return self._crouch.copy()

    def stop_posture(self) -> tuple[np.ndarray, float] | None:
        return self._crouch, CONTROLLED_STOP_SPEED_RAD_S

    def stop_action(self, walking: bool) -> str:
        return "crouching, then torque off"

    def commands(self) -> dict[type, CommandHandler]:
        return {OperatorHeartbeat: self._heartbeat, SetTorque: self._set_torque}

    # ---------------------------------------------------------------------------------------------------------
    # lifecycle

    def start(self) -> None:
        """Open the bus, check every servo answers and the tick fits the bus; torque stays off. Servos found
        holding with torque on (the process before this one died) are held where they stand, then brought down by
        the controlled stop."""
        budget = self.bus.budget(*self.sensing.bus_load())
        if budget.utilisation > 1.0:
            need_ms = budget.wire_ms_per_tick + budget.latency_ms_per_tick
            boards = " and the sensor boards" if self.sensing.boards is not None else ""
            raise BusError(
                f"{len(self.joint_names)} servos{boards} at {self.config.baudrate} baud need {need_ms:.1f} ms a tick, "
                f"more than the {1e3 / self.config.control_hz:.0f} ms period: raise the baud rate or lower the "
                "control rate"
            )
        self.bus.open()
        servos = self.bus.ping_all()
        silent = [f"{s.joint} (id {s.servo_id})" for s in servos if s.model is None]
        if silent:
            self.bus.close()
            raise BusError(f"no answer from {', '.join(silent)} on {self.config.port}")
        missing = self.sensing.start()
        if missing:
            self.links.publish("hardware/sensors", f"not found: {', '.join(missing)}", Level.WARN, missing=missing)
        with self.bus_lock:
            held = self.bus.torque_held()
            if held:  # a robot process died holding the robot up: take it over where it stands, not drop it
                changes = []
                reading = self.bus.read()
                self.bus.arm_watchdog(0)  # clears a tripped watchdog, so the servos take goals again
                self.bus.write_goals(reading.positions)
                self.bus.arm_watchdog(self.config.bus_watchdog_ms)
            else:
                changes = self.bus.prepare()  # torque off; position mode, no return delay
                reading = self.bus.read()
        publish = self.links.publish
        if changes:
            publish("hardware/setup", f"servo set-up changed: {'; '.join(changes)}", changes=changes)
        self._reading = reading
        self._positions = reading.positions.copy()
        self._targets = self._positions.copy()
        self.links.hold(self._targets)
        level = Level.WARN if not budget.fits else Level.OK
        publish(
            "hardware/bus",
            f"{len(servos)} servos on {self.config.port} at {self.config.baudrate} "
            f"baud; the bus is {budget.utilisation:.0%} busy each tick; torque off until enabled",
            level,
            utilisation=budget.utilisation,
            bytes_per_tick=budget.bytes_per_tick,
        )
        if held:  # then the controlled stop, as if this process had pressed the e-stop itself
            self._torque = True
            self._heartbeat_s = time.monotonic()
            publish(
                "hardware/takeover",
                f"found {len(held)} servos holding with torque on (a robot process died): holding them where they "
                "stand, then the controlled stop",
                Level.WARN,
                joints=held,
            )
            self.links.latch.latch(
                EStop(source="takeover", reason="the robot was found holding with torque on at start-up")
            )

    def before_shutdown(self) -> None:
        """With torque on, the controlled stop first (a robot told to shut down does not drop where it stands)."""
        links = self.links
        if self._torque and links.loop_alive():
            links.latch.latch(EStop(source="shutdown", reason="the app is shutting down"))
            links.wait_for(lambda s: not s.torque_enabled, self.estop_torque_off_s + 1.0)

    def close(self) -> None:
        """Torque off whatever happened, and let go of the port."""
        if self.perception is not None:
            self.perception.stop()
        self.sensing.stop()
        try:
            with self.bus_lock:
                self.bus.set_torque(False)
        except BusError:
            pass
        self.bus.close()

    # ---------------------------------------------------------------------------------------------------------
    # commands only the real robot has

    def _heartbeat(self, command: OperatorHeartbeat) -> CommandReply:
        self._heartbeat_s = time.monotonic()
        return CommandReply(True, "operator present")

    def _set_torque(self, command: SetTorque) -> CommandReply:
        latch = self.links.latch
        with self._lock:
            if command.enabled and latch.latched:
                return CommandReply(False, "e-stop is latched: release it first", Refusal.ESTOP_LATCHED)
            lost = self._reading.lost if self._reading is not None else ()
            if command.enabled and lost:
                return CommandReply(False, f"servos not answering: {', '.join(lost)}", Refusal.BUSY)
            self._torque_requests.append(command)
        return CommandReply(True, f"torque {'on' if command.enabled else 'off'} ({command.source})")

    def motion_refusal(self) -> CommandReply | None:
        if not self._torque:
            return CommandReply(False, "torque is off: turn it on first", Refusal.BUSY)
        return None

    def _released(self) -> None:
        self._estop_since = None

    # ---------------------------------------------------------------------------------------------------------
    # the control thread

    def before_tick(self) -> None:
        now = time.perf_counter()
        gap, self._last_tick_s = now - (self._last_tick_s or now), now
        self._apply_torque_requests()
        self._check_watchdog(max(gap, self.bus.take_longest_silence_s()))
        self._check_deadman()

    def apply_requests(self) -> None:
        """Torque requests are served first thing in the tick (`before_tick`), before the watchdog looks."""

    def _apply_torque_requests(self) -> None:
        if not self._torque_requests:
            return
        with self._lock:
            requests, self._torque_requests = self._torque_requests, []
        for command in requests:
            if command.enabled:  # hold where it stands: no jump to an old goal; the deadman starts now
                self._heartbeat_s = max(self._heartbeat_s, time.monotonic())
                self._targets = self._positions.copy()
                self.links.hold(self._targets)
                self.bus.write_goals(self._targets)
                self.bus.arm_watchdog(self.config.bus_watchdog_ms)
            self.bus.set_torque(command.enabled)
            self._torque = command.enabled
            self.links.publish("hardware/torque", f"torque {'on' if command.enabled else 'off'} ({command.source})")

    def _check_watchdog(self, gap_s: float) -> None:
        """After a stall longer than the servos' bus watchdog: they have stopped and take no goals. The stall is
        a loss of the control loop: re-arm them so the controlled stop can move, and stop."""
        watchdog_ms = self.config.bus_watchdog_ms
        if not (self._torque and watchdog_ms and gap_s * 1e3 > watchdog_ms):
            return
        tripped = self.bus.watchdog_tripped()
        if not tripped:
            return
        self.bus.arm_watchdog(watchdog_ms)
        reason = f"the control loop stalled for {gap_s * 1e3:.0f} ms"
        self.links.publish(
            "hardware/watchdog",
            f"{reason}: the bus watchdog stopped {len(tripped)} servos where they were",
            Level.ERROR,
            joints=tripped,
            gap_ms=round(gap_s * 1e3, 1),
        )
        self.links.latch.latch(EStop(source="watchdog", reason=reason))

    def _check_deadman(self) -> None:
        """Torque on with no operator heartbeat for `deadman_s` (the page closed, the network or the browser
        hung): the controlled stop, then torque off, as for an e-stop."""
        if not (self._torque and self.deadman_s and self._estop_since is None):
            return
        silent_s = time.monotonic() - self._heartbeat_s
        if silent_s > self.deadman_s and not self.links.latch.latched:
            reason = f"no operator heartbeat for {silent_s:.1f} s (deadman {self.deadman_s:g} s)"
            self.links.latch.latch(EStop(source="deadman", reason=reason))

    def sense(self) -> Measurements:
        started = self._tick_started = time.perf_counter()
        reading = self.bus.read()
        newly_lost = set(reading.lost) - set(self._reading.lost if self._reading is not None else ())
        self._reading = reading
        self._positions = np.where(np.isfinite(reading.positions), reading.positions, self._positions)
        # the load said in diagnostics is sustained load, as the simulation's: a step's spike is not an alarm
        load = np.nan_to_num(reading.currents_a) / STALL_CURRENT_A * 100.0
        self._load_pct += (load - self._load_pct) * min(1.0, self.dt / LOAD_AVERAGE_S)
        for joint in sorted(newly_lost):
            self.links.publish("hardware/servo_lost", f"servo of {joint} stopped answering", Level.ERROR, joint=joint)
        lost = self.sensing.read()
        self._bus_s = time.perf_counter() - started
        for sense in lost:
            self._sense_lost(sense)
        return self.latest()

    def _sense_lost(self, sense: str) -> None:
        """Said; with torque on the robot may be balancing on it: the controlled stop."""
        self.links.publish("hardware/sensor_lost", f"{sense} stopped: no readings", Level.ERROR, sensor=sense)
        if self._torque and not self.links.latch.latched:
            self.links.latch.latch(EStop(source="sensor", reason=f"{sense} stopped giving readings"))

    def latest(self) -> Measurements:
        return Measurements(
            self.now(), self._positions, self._zero_velocities, np.array(self._base), **self.sensing.fields()
        )

    def actuate(self, targets: np.ndarray) -> Measurements:
        if self._torque:
            self._targets = targets
            if self._estop_since is not None and time.monotonic() - self._estop_since > self.estop_torque_off_s:
                self.bus.set_torque(False)
                self._torque = False
                self._estop_since = None
                self.links.publish("hardware/torque", "torque off: the e-stop's controlled stop is done", Level.WARN)
            else:
                started = time.perf_counter()
                self.bus.write_goals(targets)
                self._bus_s += time.perf_counter() - started
                if self._stop_applied_at is not None:  # a stop while walking: the step's next goals
                    self._stop_on_bus(time.time())
        else:
            self._targets = self._positions.copy()  # goal follows the limp robot: enabling torque holds it there
            self.links.hold(self._targets)
        return self.latest()

    def hold_now(self, targets: np.ndarray) -> None:
        """The stop's first goals, on the bus at once (the loop holds the bus's lock); the move to the stop
        posture follows tick by tick on the posture controller."""
        if self._torque:
            self._targets = targets
            self.bus.write_goals(targets)
            self._stop_written_at = time.time()

    def stop_applied(self) -> None:
        self._estop_since = time.monotonic()
        if not self._torque:  # a limp robot: no goals to stop
            return
        self._stop_applied_at = time.time()  # (the clock the latch says the stop was applied by)
        if self._stop_written_at is not None:
            self._stop_on_bus(self._stop_written_at)

    def _stop_on_bus(self, written_at: float) -> None:
        """Said once the controlled stop's first goals are written: where an e-stop really reaches the robot
        (timed from when the stop was applied: written just before, by `hold_now`, it is a hair below zero)."""
        assert self._stop_applied_at is not None
        after_ms = (written_at - self._stop_applied_at) * 1e3
        self._stop_applied_at = self._stop_written_at = None
        when = f"{after_ms:.1f} ms after the stop was applied" if after_ms > 0 else "as the stop was applied"
        message = f"the controlled stop's first goals are on the bus, {when}"
        self.links.publish("hardware/stop_on_bus", message, after_applied_ms=round(after_ms, 3))

    def after_tick(self, targets: np.ndarray, tick_s: float) -> None:
        """The tick's bus time and compute (no battery model or telemetry on the real robot yet)."""
        self.tick_split.record(self._bus_s, tick_s)
        self._bus_s = 0.0
        self._read_monitoring()

    def _read_monitoring(self) -> None:
        """The servos' slow blocks (hardware errors, voltage, temperature) in the period's slack, after the goals
        are out: read inside the tick they made about one tick in 70 miss its deadline on the rig at 2 Mbps."""
        if self.bus.slow_due:  # (a port that is gone: the next tick's own read meets it, and says it)
            with self.bus_lock, contextlib.suppress(OSError):
                self.bus.read_slow_if_room(self.dt - (time.perf_counter() - self._tick_started))

    def snapshot(self, measured: Measurements) -> BodySnapshot:
        sensed = bool(np.isfinite(measured.imu_quat).all())
        tilt = measured.tilt_deg if sensed else 0.0
        if sensed:
            self._watch_fall(tilt)
        base, yaw = self._estimated_base()
        return BodySnapshot(
            base_position=base,
            base_yaw_rad=yaw if yaw is not None else measured.yaw_rad if sensed else self._yaw,
            tilt_deg=tilt,
            fallen=tilt > FALL_TILT_DEG,
            qpos=tuple(self.scene.qpos_with_joints(self._positions).tolist()),
            torque_enabled=self._torque,
        )

    def locate_by(self, trunk: Callable[[], tuple[np.ndarray, np.ndarray]]) -> None:
        """Where the robot is, for its state and the mirror: the legs' estimate of its trunk (position, rotation)
        in the map, once it walks (the real robot has no other)."""
        self._trunk_estimate = trunk

    def _estimated_base(self) -> tuple[tuple[float, float, float], float | None]:
        if self._trunk_estimate is None:
            return self._base, None
        position, rotation = self._trunk_estimate()
        if not (np.isfinite(position).all() and np.isfinite(rotation).all()):  # not placed yet
            return self._base, None
        return (float(position[0]), float(position[1]), float(position[2])), math.atan2(rotation[1, 0], rotation[0, 0])

    def _watch_fall(self, tilt_deg: float) -> None:
        """A fall with torque on: the controlled stop (the core holds the joints; the real robot then crouches and
        lets go). Picked up and upright again with torque off, the robot may move again (no reset on hardware)."""
        latch = self.links.latch
        if tilt_deg > FALL_TILT_DEG and self._torque and not latch.latched:
            latch.latch(EStop(source="fall", reason=f"the robot fell (tilt {tilt_deg:.0f} deg)"))
        elif latch.fallen and tilt_deg < UPRIGHT_TILT_DEG and not self._torque:
            latch.stand_up()
            self.links.publish("hardware/upright", f"upright again (tilt {tilt_deg:.0f} deg): torque on to move")

    def tick_error(self, exc: Exception) -> bool:
        if isinstance(exc, BusError):  # said, and the next tick tries again (lost servos are diagnostics' part)
            self.links.publish("hardware/bus", f"bus error: {exc}", Level.ERROR)
            return True
        return False

    def after_safe_stop(self) -> None:
        if not self.links.loop_alive() or self.links.tick_age_s() > 0.5:
            self._torque_off_now("the control loop is not running")

    def _torque_off_now(self, why: str) -> None:
        """From outside the control loop (it hangs, or died): torque off if the bus can be had within 0.1 s."""
        if self.bus_lock.acquire(timeout=0.1):
            try:
                self.bus.set_torque(False)
                self._torque = False
                self.links.publish("hardware/torque", f"torque off: {why}", Level.ERROR)
            except BusError as exc:
                self.links.publish("hardware/torque", f"could not turn torque off ({why}): {exc}", Level.ERROR)
            finally:
                self.bus_lock.release()

    def readings(
        self,
        stats: LoopStats,
        perception: Callable[[], PerceptionState | None],
        sensor_feed: Callable[[], SensorFeed],
        voice: Callable[[], Any],
    ) -> RobotReadings:
        # the perception's camera and lidar (a walking robot's: detections and the map), besides their drivers
        perceives = tuple(
            name
            for name, device in (("camera", self.sensing.camera), ("lidar", self.sensing.lidar))
            if device is not None and self.perception is not None
        )
        return RobotReadings(
            joint_names=self.joint_names,
            stats=stats,
            servos=self._servo_readings,
            power=lambda: None,
            battery_cells=0,
            perception=perception if perceives else lambda: None,
            sensor_feed=sensor_feed if perceives else SensorFeed,
            sim_time=self.now,
            imu_stamp=lambda: None,
            voice=lambda: None,
            sensor_hz=SENSOR_HZ,
            has_imu=False,
            perceives=perceives,
            lost_servos=lambda: self._reading.lost if self._reading is not None else (),
            hardware_ids=[f"XM430-W350 id {j.servo_id}" for j in self.config.joints],
            devices=lambda: [*self.sensing.statuses(), self._bus_status()],
            locomotion=lambda: self.links.latest_state().locomotion,
        )

    def _bus_status(self) -> DiagnosticStatus:
        """The tick's time on the bus (servos, sensor boards, goals) and the rest, its compute: said when the bus
        alone takes most of the control period."""
        split = self.tick_split.summary()
        period_ms = self.dt * 1e3
        busy = split["bus_p99_ms"] > BUS_WARN_SHARE * period_ms
        message = (
            f"the bus takes {split['bus_p99_ms']:.1f} ms of the {period_ms:.0f} ms tick at p99 (compute "
            f"{split['compute_p99_ms']:.1f} ms): raise the baud rate, lower the control rate or read less"
            if busy
            else f"bus {split['bus_p50_ms']:.1f} ms a tick (p99 {split['bus_p99_ms']:.1f}), compute "
            f"{split['compute_p99_ms']:.1f} ms at p99"
        )
        values = tuple((key, round(value, 3)) for key, value in split.items())
        return DiagnosticStatus("hardware/bus", Level.WARN if busy else Level.OK, message, self.config.port, values)

    def _servo_readings(self) -> ServoReadings:
        r = self._reading
        n = len(self.joint_names)
        if r is None:
            return ServoReadings(*(np.zeros(n) for _ in range(5)), np.zeros(n, dtype=np.int64))
        return ServoReadings(
            temperature_c=r.temperatures_c,
            current_a=r.currents_a,
            voltage_v=r.voltages_v,
            load_pct=self._load_pct.copy(),
            position_error_rad=(self._targets - self._positions) if self._torque else np.zeros(n),
            error_bits=r.hardware_errors,
        )

    def reset(self, stand: np.ndarray) -> Measurements:
        raise NotImplementedError(f"reset {NOT_ON_HARDWARE}")

    def place(self, stand: np.ndarray) -> Measurements:
        raise NotImplementedError(f"placing the robot {NOT_ON_HARDWARE}")
