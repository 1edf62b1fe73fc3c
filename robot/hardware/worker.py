"""The real robot behind the same `RobotPort` as the simulator: XM430s on a Dynamixel bus, driven at a fixed rate.

What it does on hardware today: torque on and off (off at start-up until the operator turns it on), postures
(stand, crouch) at a capped joint speed, the e-stop (the controlled-stop posture, a slow crouch, then torque off),
the same stop when the control loop stalls past the servos' bus watchdog (which has already stopped them where
they were) or the browser's deadman lapses, every goal clamped to the joint's limits, servos that stop answering
or latch a hardware error surfaced in diagnostics (and stopping the robot), and the measured pose for the 3D
mirror. Walking, perception and plans need the IMU, cameras and feet sensors the servo bus does not carry: they
are refused with that reason.
"""

from __future__ import annotations

import threading
import time
from typing import Any

import numpy as np

from robot.control.posture import PostureController
from robot.control.priority import raise_thread_priority
from robot.control.stats import LoopStats
from robot.diagnostics.robot_sources import RobotDiagnostics, RobotReadings
from robot.diagnostics.thresholds import Thresholds
from robot.events import EventBus, Subscription
from robot.hardware.bus import BusError, DynamixelBus
from robot.hardware.config import HardwareConfig
from robot.hardware.xm430 import STALL_CURRENT_A, ServoReadings
from robot.in_process import InProcessPort
from robot.interface import (
    CommandReply,
    DiagnosticArray,
    EStop,
    Event,
    Level,
    Mode,
    OperatorHeartbeat,
    Posture,
    Refusal,
    ReleaseEStop,
    RobotDescription,
    RobotState,
    SensorFeed,
    SetPosture,
    SetTorque,
)
from robot.model import humanoid_v1
from robot.model.scene import scene_xml
from robot.model.world import WorldLayout
from robot.sim.backend import MujocoSimBackend
from robot.state_board import StateBoard

ESTOP_TORQUE_OFF_AFTER_S = 3.0  # the controlled stop's crouch has this long before torque goes off
DEADMAN_S = 1.5  # torque on needs an operator heartbeat at least this often (the page sends one every 250 ms)
CONTROLLED_STOP_SPEED_RAD_S = 0.6
NOT_ON_HARDWARE = "needs the IMU, cameras and foot sensors, which are not on the servo bus: simulation only for now"


class HardwareWorker(InProcessPort):
    def __init__(
        self,
        config: HardwareConfig,
        layout: WorldLayout,
        bus: DynamixelBus | None = None,
        diagnostics: Thresholds | None = None,
        disk_path: str = ".",
        estop_torque_off_s: float = ESTOP_TORQUE_OFF_AFTER_S,
        deadman_s: float = DEADMAN_S,
    ) -> None:
        """`deadman_s`: 0 turns the operator deadman off (a script that keeps torque on by itself, at its risk)."""
        self.config = config
        self.layout = layout
        self.bus = bus or DynamixelBus(config)
        self.control_hz = config.control_hz
        self.estop_torque_off_s = estop_torque_off_s
        self.deadman_s = deadman_s
        self._heartbeat_s = time.monotonic()
        self.dt = 1.0 / config.control_hz
        self.joint_names = config.joint_names
        self._scene = MujocoSimBackend(layout)  # never stepped: the model the mirror draws the measured pose in
        self._bus_lock = threading.Lock()
        self._lock = threading.RLock()
        self._events = EventBus()
        self._board = StateBoard()
        self._stats = LoopStats(self.control_hz)
        self._stand = np.array([humanoid_v1.stand_posture()[n] for n in self.joint_names])
        self._crouch = np.array([humanoid_v1.stand_posture(humanoid_v1.CROUCH_KNEE_BEND)[n] for n in self.joint_names])
        self._posture = PostureController(self._stand)
        self._torque = False
        self._estop_latched = False
        self._estop_since: float | None = None
        self._pending: list[Any] = []
        self._positions = np.zeros(len(self.joint_names))
        self._targets = self._positions.copy()
        self._reading = None
        self._last_tick_s: float | None = None
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._started_at = time.monotonic()
        self._diagnostics = RobotDiagnostics(
            RobotReadings(
                joint_names=self.joint_names,
                stats=self._stats,
                servos=self._servo_readings,
                power=lambda: None,
                battery_cells=0,
                perception=lambda: None,
                sensor_feed=SensorFeed,
                sim_time=self._clock,
                imu_stamp=lambda: None,
                voice=lambda: None,
                sensor_hz=0.0,
                has_imu=False,
                lost_servos=lambda: self._reading.lost if self._reading is not None else (),
                hardware_ids=[f"XM430-W350 id {j.servo_id}" for j in config.joints],
            ),
            diagnostics or Thresholds(),
            True,
            disk_path,
            None,
            "none (hardware)",
            self._events.publish,
            self._safe_stop,
        )

    # lifecycle -------------------------------------------------------------------------------------------------

    def start(self) -> None:
        """Open the bus, check every servo answers and the tick fits the bus; torque stays off. Servos found
        holding with torque on (the process before this one died) are held where they stand, then brought down by
        the controlled stop."""
        budget = self.bus.budget()
        if budget.utilisation > 1.0:
            need_ms = budget.wire_ms_per_tick + budget.latency_ms_per_tick
            raise BusError(
                f"{len(self.joint_names)} servos at {self.config.baudrate} baud need {need_ms:.1f} ms a tick, more "
                f"than the {1e3 / self.control_hz:.0f} ms period: raise the baud rate or lower the control rate"
            )
        self.bus.open()
        servos = self.bus.ping_all()
        silent = [f"{s.joint} (id {s.servo_id})" for s in servos if s.model is None]
        if silent:
            self.bus.close()
            raise BusError(f"no answer from {', '.join(silent)} on {self.config.port}")
        with self._bus_lock:
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
        if changes:
            self._events.publish("hardware/setup", f"servo set-up changed: {'; '.join(changes)}", changes=changes)
        self._reading = reading
        self._positions = reading.positions.copy()
        self._targets = self._positions.copy()
        self._posture.hold(self._targets)
        level = Level.WARN if not budget.fits else Level.OK
        self._events.publish(
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
            self._events.publish("hardware/takeover", f"found {len(held)} servos holding with torque on (a robot "
                                 "process died): holding them where they stand, then the controlled stop",
                                 Level.WARN, joints=held)  # fmt: skip
            self.submit(EStop(source="takeover", reason="the robot was found holding with torque on at start-up"))
        self._publish_state()
        self._thread = threading.Thread(target=self._control_loop, name="robot-control", daemon=True)
        self._thread.start()
        self._diagnostics.start()

    def stop(self) -> None:
        """With torque on, the controlled stop first (a robot told to shut down does not drop where it stands);
        then torque off whatever happened."""
        if self._torque and self.is_alive():
            self.submit(EStop(source="shutdown", reason="the app is shutting down"))
            self._board.wait_for(lambda s: not s.torque_enabled, self.estop_torque_off_s + 1.0)
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2)
        self._diagnostics.stop()
        try:
            with self._bus_lock:
                self.bus.set_torque(False)
        except BusError:
            pass
        self.bus.close()

    def is_alive(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    # RobotPort -------------------------------------------------------------------------------------------------

    def submit(self, command: Any) -> CommandReply:
        if isinstance(command, OperatorHeartbeat):
            self._heartbeat_s = time.monotonic()
            return CommandReply(True, "operator present")
        if isinstance(command, EStop):
            with self._lock:
                if not self._estop_latched:
                    self._estop_latched = True
                    self._pending.append(command)
            return CommandReply(True, "e-stop latched: crouching, then torque off")
        if isinstance(command, ReleaseEStop):
            with self._lock:
                if not self._estop_latched:
                    return CommandReply(False, "e-stop is not latched", Refusal.NOT_LATCHED)
                unsafe = self._diagnostics.unsafe()
                if unsafe:
                    faults = "; ".join(f"{s.name}: {s.message}" for s in unsafe)
                    return CommandReply(False, f"motion is unsafe until this is fixed: {faults}", Refusal.ESTOP_LATCHED)
                self._estop_latched = False
                self._estop_since = None
            self._events.publish("estop/released", f"E-STOP released ({command.source}); torque stays off")
            return CommandReply(True, "e-stop released; turn torque on to move again")
        if isinstance(command, SetTorque):
            return self._set_torque(command)
        if isinstance(command, SetPosture):
            with self._lock:
                if self._estop_latched:
                    return CommandReply(False, "e-stop is latched: release it first", Refusal.ESTOP_LATCHED)
                if not self._torque:
                    return CommandReply(False, "torque is off: turn it on first", Refusal.BUSY)
                goal = self._stand if command.posture == Posture.STAND else self._crouch
                self._posture.move_to(goal)
            return CommandReply(True, f"moving to {command.posture.value}")
        name = type(command).__name__
        return CommandReply(False, f"{name} {NOT_ON_HARDWARE}", Refusal.UNSUPPORTED)

    def state(self) -> RobotState:
        return self._board.latest()

    def announce(self, kind: str, message: str, level: Level = Level.OK, **data: Any) -> Event:
        """An event from the server about the robot (e.g. a refused 3D-view click), said like the robot's own."""
        return self._bus.publish(kind, message, level, **data)

    def subscribe(self) -> Subscription:
        return self._events.subscribe()

    def recent_events(self) -> list[Event]:
        return self._events.history()

    def describe(self) -> RobotDescription:
        return RobotDescription(
            model_name=humanoid_v1.MODEL_NAME,
            seed=self.layout.seed,
            mjcf_xml=scene_xml(self.layout),
            joint_names=self.joint_names,
            places=self.layout.place_names,
            objects=self.layout.object_names,
            control_hz=self.control_hz,
            physics_hz=0.0,
            planner="none (hardware)",
        )

    def sensor_feed(self) -> SensorFeed:
        return SensorFeed()

    def telemetry_since(self, seq: int) -> None:
        return None

    def diagnostics(self) -> DiagnosticArray | None:
        return self._diagnostics.latest()

    def wait_for(self, predicate: Any, timeout_s: float) -> bool:
        return self._board.wait_for(predicate, timeout_s)

    # internals -------------------------------------------------------------------------------------------------

    def _clock(self) -> float:
        return time.monotonic() - self._started_at

    def _set_torque(self, command: SetTorque) -> CommandReply:
        with self._lock:
            if command.enabled and self._estop_latched:
                return CommandReply(False, "e-stop is latched: release it first", Refusal.ESTOP_LATCHED)
            lost = self._reading.lost if self._reading is not None else ()
            if command.enabled and lost:
                return CommandReply(False, f"servos not answering: {', '.join(lost)}", Refusal.BUSY)
            self._pending.append(command)
        return CommandReply(True, f"torque {'on' if command.enabled else 'off'} ({command.source})")

    def _safe_stop(self, reason: str) -> None:
        self._events.publish("diagnostics/safe_stop", f"safe stop: {reason}", Level.ERROR, reason=reason)
        self.submit(EStop(source="diagnostics", reason=reason))
        if (self._thread is not None and not self._thread.is_alive()) or self._tick_age() > 0.5:
            self._torque_off_now("the control loop is not running")

    def _tick_age(self) -> float:
        return time.perf_counter() - self._stats.last_tick_end

    def _torque_off_now(self, why: str) -> None:
        """From outside the control loop (it hangs, or died): torque off if the bus can be had within 0.1 s."""
        if self._bus_lock.acquire(timeout=0.1):
            try:
                self.bus.set_torque(False)
                self._torque = False
                self._events.publish("hardware/torque", f"torque off: {why}", Level.ERROR)
            except BusError as exc:
                self._events.publish("hardware/torque", f"could not turn torque off ({why}): {exc}", Level.ERROR)
            finally:
                self._bus_lock.release()

    def _apply_pending(self) -> None:
        with self._lock:
            pending, self._pending = self._pending, []
        for command in pending:
            if isinstance(command, EStop):
                self._estop_since = time.monotonic()
                self._posture.hold(self._targets)
                self._posture.move_to(self._crouch, CONTROLLED_STOP_SPEED_RAD_S)
                why = f" because {command.reason}" if command.reason else ""
                self._events.publish(
                    "estop/latched",
                    f"E-STOP latched ({command.source}){why}: crouching, then torque off",
                    Level.ERROR,
                    source=command.source,
                    reason=command.reason,
                )
            elif isinstance(command, SetTorque):
                if command.enabled:  # hold where it stands: no jump to an old goal; the deadman starts now
                    self._heartbeat_s = max(self._heartbeat_s, time.monotonic())
                    self._targets = self._positions.copy()
                    self._posture.hold(self._targets)
                    self.bus.write_goals(self._targets)
                    self.bus.arm_watchdog(self.config.bus_watchdog_ms)
                self.bus.set_torque(command.enabled)
                self._torque = command.enabled
                self._events.publish(
                    "hardware/torque", f"torque {'on' if command.enabled else 'off'} ({command.source})"
                )

    def _control_loop(self) -> None:
        priority = raise_thread_priority()
        self._events.publish("control/priority", f"control loop at {self.control_hz:.0f} Hz with {priority}",
                             Level.OK if priority.startswith("real-time") else Level.WARN)  # fmt: skip
        next_deadline = time.perf_counter() + self.dt
        self._stats.last_tick_end = time.perf_counter()
        while not self._stop.is_set():
            remaining = next_deadline - time.perf_counter()
            if remaining > 0:
                self._stop.wait(remaining)
                continue
            started = time.perf_counter()
            try:
                with self._bus_lock:
                    self._tick()
            except BusError as exc:
                self._events.publish("hardware/bus", f"bus error: {exc}", Level.ERROR)
            finished = time.perf_counter()
            self._stats.record_tick(finished - started, finished > next_deadline + self.dt)
            self._stats.update_rtf(self._clock())
            next_deadline += self.dt
            if finished - next_deadline > 5 * self.dt:
                next_deadline = finished + self.dt

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
        self._events.publish(
            "hardware/watchdog",
            f"{reason}: the bus watchdog stopped {len(tripped)} servos where they were",
            Level.ERROR,
            joints=tripped,
            gap_ms=round(gap_s * 1e3, 1),
        )
        self.submit(EStop(source="watchdog", reason=reason))
        self._apply_pending()

    def _check_deadman(self) -> None:
        """Torque on with no operator heartbeat for `deadman_s` (the page closed, the network or the browser
        hung): the controlled stop, then torque off, as for an e-stop."""
        if not (self._torque and self.deadman_s and self._estop_since is None):
            return
        silent_s = time.monotonic() - self._heartbeat_s
        if silent_s > self.deadman_s:
            reason = f"no operator heartbeat for {silent_s:.1f} s (deadman {self.deadman_s:g} s)"
            self.submit(EStop(source="deadman", reason=reason))
            self._apply_pending()

    def _tick(self) -> None:
        now = time.perf_counter()
        gap, self._last_tick_s = now - (self._last_tick_s or now), now
        self._apply_pending()
        self._check_watchdog(gap)
        self._check_deadman()
        reading = self.bus.read()
        newly_lost = set(reading.lost) - set(self._reading.lost if self._reading is not None else ())
        self._reading = reading
        self._positions = np.where(np.isfinite(reading.positions), reading.positions, self._positions)
        for joint in sorted(newly_lost):
            self._events.publish("hardware/servo_lost", f"servo of {joint} stopped answering", Level.ERROR, joint=joint)
        if self._torque:
            self._targets = self._posture.update(self.dt)
            if self._estop_since is not None and time.monotonic() - self._estop_since > self.estop_torque_off_s:
                self.bus.set_torque(False)
                self._torque = False
                self._estop_since = None
                self._events.publish("hardware/torque", "torque off: the e-stop's controlled stop is done", Level.WARN)
            else:
                self.bus.write_goals(self._targets)
        else:
            self._targets = self._positions.copy()  # goal follows the limp robot: enabling torque holds it there
        self._publish_state()

    def _servo_readings(self) -> ServoReadings:
        r = self._reading
        n = len(self.joint_names)
        if r is None:
            return ServoReadings(*(np.zeros(n) for _ in range(5)), np.zeros(n, dtype=np.int64))
        return ServoReadings(
            temperature_c=r.temperatures_c,
            current_a=r.currents_a,
            voltage_v=r.voltages_v,
            load_pct=r.currents_a / STALL_CURRENT_A * 100.0,
            position_error_rad=(self._targets - self._positions) if self._torque else np.zeros(n),
            error_bits=r.hardware_errors,
        )

    def _publish_state(self) -> None:
        with self._lock:
            latched = self._estop_latched
        mode = Mode.ESTOP if latched else Mode.IDLE
        base = self.layout.robot_start
        self._board.publish(
            RobotState(
                sim_time_s=self._clock(),
                wall_time_s=time.time(),
                mode=mode,
                estop_latched=latched,
                base_position=(base[0], base[1], 0.0),
                base_yaw_rad=base[2] if len(base) > 2 else 0.0,
                tilt_deg=0.0,
                fallen=False,
                qpos=tuple(self._scene.qpos_with_joints(self._positions).tolist()),
                objects=(),
                held_object=None,
                plan=None,
                control=self._stats.snapshot(),
                torque_enabled=self._torque,
            )
        )
