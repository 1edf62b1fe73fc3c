"""Diagnostics without a running robot: the simulated XM430s' physics, every threshold of the checks, and the
monitor's alarms and safe stop."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robot.diagnostics.checks import control_status, gait_status, power_status, sensor_statuses, servo_statuses
from robot.diagnostics.monitor import DiagnosticsMonitor
from robot.diagnostics.thresholds import Thresholds
from robot.hardware import xm430
from robot.hardware.xm430 import HardwareError, ServoReadings
from robot.interface import ControlStats, DiagnosticStatus, Level, PerceptionState, PowerState
from robot.power.battery import ServoElectrical
from robot.sim.servo_model import SimulatedServos, ThermalSpec

LIMITS = Thresholds()


def run(servos: SimulatedServos, torque_nm: float, seconds: float, dt: float = 0.01) -> None:
    n = len(servos.joint_names)
    for _ in range(round(seconds / dt)):
        servos.step(np.full(n, torque_nm), np.zeros(n), np.zeros(n), 12.0, dt)


def test_a_servo_warms_to_the_steady_state_its_copper_losses_set() -> None:
    servos = SimulatedServos(["knee"])
    electrical, thermal = ServoElectrical(), ThermalSpec()
    torque = 1.0 * electrical.torque_constant  # about 1.04 A with the standby current
    current = electrical.currents_a(np.array([torque]))[0]
    rise = current**2 * electrical.resistance_ohm * thermal.winding_to_ambient_k_per_w
    tau = thermal.winding_to_ambient_k_per_w * thermal.heat_capacity_j_per_k
    run(servos, torque, tau, dt=0.1)
    assert servos.temperature_c[0] - thermal.ambient_c == pytest.approx(rise * (1 - math.exp(-1)), rel=0.01)
    run(servos, torque, 6 * tau, dt=0.5)
    assert servos.temperature_c[0] == pytest.approx(thermal.ambient_c + rise, rel=0.01)
    assert servos.readings().current_a[0] == pytest.approx(current)
    run(servos, 0.0, 8 * tau, dt=0.5)  # unloaded, it cools back to the air's temperature
    assert servos.temperature_c[0] == pytest.approx(thermal.ambient_c, abs=0.5)


def test_overload_trips_after_a_held_stall_and_latches_until_a_reboot() -> None:
    servos = SimulatedServos(["ankle", "knee"])
    run(servos, xm430.STALL_TORQUE_NM, xm430.OVERLOAD_AFTER_S - 0.1)
    assert not servos.readings().error_bits.any()
    run(servos, xm430.STALL_TORQUE_NM, 0.2)
    assert HardwareError.OVERLOAD in HardwareError(int(servos.readings().error_bits[0]))
    run(servos, 0.0, 1.0)
    assert servos.readings().error_bits[0]  # latched, as on the real servo
    servos.reboot()
    assert not servos.readings().error_bits.any()


def test_a_jam_holds_the_load_whatever_is_asked_and_heat_is_injected_where_named() -> None:
    servos = SimulatedServos(["ankle", "knee"])
    servos.jam("knee", 100)
    servos.heat("ankle", 60)
    run(servos, 0.0, 0.05)
    readings = servos.readings()
    assert readings.load_pct[1] == pytest.approx(5, abs=0.5)  # the reported load is averaged over a second
    run(servos, 0.0, 5.0)
    readings = servos.readings()
    assert readings.load_pct[1] > 99 and readings.load_pct[0] < 2
    assert readings.temperature_c[0] >= 84 and HardwareError.OVERHEATING in HardwareError(int(readings.error_bits[0]))
    with pytest.raises(ValueError, match="no servo drives"):
        servos.heat("tail", 1)
    servos.clear_faults()
    run(servos, 0.0, 5.0)
    assert servos.readings().load_pct[1] < 2


def _readings(**overrides) -> ServoReadings:
    base = dict(
        temperature_c=[40.0],
        current_a=[0.3],
        voltage_v=[12.0],
        load_pct=[10.0],
        position_error_rad=[0.01],
        error_bits=[0],
    )
    base.update(overrides)
    return ServoReadings(**{k: np.array(v) for k, v in base.items()})


@pytest.mark.parametrize(
    ("overrides", "level", "words", "stops"),
    [
        ({}, Level.OK, "40 C", False),
        ({"temperature_c": [66.0]}, Level.WARN, "hot", False),
        ({"temperature_c": [76.0]}, Level.ERROR, "overheating", True),
        ({"load_pct": [85.0]}, Level.WARN, "heavily loaded", False),
        ({"position_error_rad": [-0.4]}, Level.WARN, "position error 23 deg", False),
        ({"error_bits": [int(HardwareError.INPUT_VOLTAGE)]}, Level.ERROR, "input voltage", True),
    ],
)
def test_servo_levels(overrides, level, words, stops) -> None:
    (status,) = servo_statuses(["r_knee"], _readings(**overrides), LIMITS)
    assert status.name == "servos/r_knee" and status.level == level and words in status.message
    assert status.stops_motion == stops


def test_battery_levels_follow_charge_and_sag() -> None:
    def level(volts: float, soc: float) -> Level:
        return power_status(PowerState(volts, 2.0, soc, 40.0), 6, LIMITS).level

    assert level(23.5, 0.8) == Level.OK
    assert level(22.0, 0.18) == Level.WARN
    assert level(20.5, 0.5) == Level.WARN  # 3.42 V a cell under load: sagging
    assert level(19.0, 0.5) == Level.ERROR
    assert level(22.0, 0.08) == Level.ERROR
    assert power_status(None, 6, LIMITS).level == Level.STALE


def test_control_loop_levels() -> None:
    stats = ControlStats(tick_p50_ms=3.0, tick_p99_ms=4.0, ticks=1000, rtf=1.0, control_hz=100.0)
    assert control_status(stats, 0.01, 0.0, True, LIMITS).level == Level.OK
    slow = ControlStats(tick_p50_ms=6.0, tick_p99_ms=9.5, ticks=1000, rtf=1.0, control_hz=100.0)
    assert "tick p99" in control_status(slow, 0.01, 0.0, True, LIMITS).message
    stale = control_status(stats, 0.8, 0.0, True, LIMITS)
    assert stale.level == Level.ERROR and stale.stops_motion and "stale" in stale.message
    assert control_status(stats, 0.8, 0.0, False, LIMITS).level == Level.OK  # headless: no wall-clock deadline
    assert "deadline misses" in control_status(stats, 0.01, 5.0, True, LIMITS).message


def test_late_walk_plans_are_said_when_they_come_often() -> None:
    on_time = gait_status(0, 0.0, 1.0, LIMITS)
    assert on_time.level == Level.OK and on_time.name == "control/gait"
    assert gait_status(1, 0.05, 1.0, LIMITS).level == Level.OK  # one now and then: the walk carries on
    busy = gait_status(5, 0.25, 1.0, LIMITS)
    assert busy.level == Level.WARN and "5 walk plans came late" in busy.message and "50 ms" in busy.message
    assert not busy.stops_motion


def test_sensor_levels() -> None:
    perception = PerceptionState("ok", camera_hz=10.0, lidar_hz=6.0)
    statuses = {s.name: s for s in sensor_statuses(perception, 20.0, 19.9, 17.0, 0.0, 10.0, LIMITS)}
    assert statuses["sensors/camera"].level == Level.OK
    lidar = statuses["sensors/lidar"]
    assert lidar.level == Level.STALE and "no lidar data for 3.0 s" in lidar.message
    assert statuses["sensors/imu"].level == Level.OK
    slow = {s.name: s for s in sensor_statuses(perception, 20.0, 19.9, 19.9, 0.0, 10.0, LIMITS)}
    starting = {s.name: s for s in sensor_statuses(perception, 1.0, 0.9, 0.9, 0.0, 10.0, LIMITS)}
    assert starting["sensors/lidar"].level == Level.OK  # its first scans come unevenly
    assert slow["sensors/lidar"].level == Level.WARN
    imu = {s.name: s for s in sensor_statuses(None, 20.0, None, None, 0.2, 10.0, LIMITS)}
    assert imu["sensors/imu"].level == Level.ERROR and imu["sensors/imu"].stops_motion
    assert "sensors/camera" not in imu  # no perception: no camera to judge


class _Source:
    def __init__(self) -> None:
        self.status = DiagnosticStatus("servos/r_knee", Level.OK, "fine")

    def __call__(self) -> list[DiagnosticStatus]:
        return [self.status]


def test_the_monitor_reports_changes_once_and_stops_the_robot_once_per_fault() -> None:
    source = _Source()
    events: list[tuple[str, Level]] = []
    stops: list[str] = []
    monitor = DiagnosticsMonitor(
        [source, lambda: 1 / 0],
        lambda kind, message, level=Level.OK, **data: events.append((kind, level)),
        stops.append,
        lambda: 12.0,
    )
    first = monitor.sample()
    assert first.find("diagnostics/monitor").level == Level.WARN  # the broken source is reported, the rest goes on
    events.clear()
    source.status = DiagnosticStatus("servos/r_knee", Level.ERROR, "overheating", stops_motion=True)
    monitor.sample()
    monitor.sample()
    assert events == [("diagnostics/alarm", Level.ERROR)] and stops == ["servos/r_knee: overheating"]
    assert [s.name for s in monitor.unsafe()] == ["servos/r_knee"]
    source.status = DiagnosticStatus("servos/r_knee", Level.OK, "cool")
    monitor.sample()
    assert events[-1] == ("diagnostics/recovered", Level.OK) and monitor.unsafe() == []
    assert monitor.latest().sim_time_s == 12.0 and monitor.latest().level == Level.WARN
