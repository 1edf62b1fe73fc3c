"""Readings to statuses: pure functions, one per component, so every threshold is tested without a robot."""

from __future__ import annotations

from collections.abc import Collection, Sequence

import numpy as np

from robot.diagnostics.thresholds import Thresholds
from robot.hardware.xm430 import HardwareError, ServoReadings
from robot.interface import ControlStats, DiagnosticStatus, Level, PerceptionState, PowerState

RATE_SETTLED_S = 3.0  # a sensor's rate is judged once it has run this long (its first frames come unevenly)


def control_status(
    stats: ControlStats, tick_age_s: float | None, misses_per_s: float, realtime: bool, limits: Thresholds
) -> DiagnosticStatus:
    """The fixed-rate loop: on time, fast enough, and alive (`tick_age_s`: since its last tick, wall clock)."""
    period_ms = 1e3 / stats.control_hz if stats.control_hz else 10.0
    values = (
        ("rate_hz", stats.control_hz),
        ("tick_p50_ms", stats.tick_p50_ms),
        ("tick_p99_ms", stats.tick_p99_ms),
        ("tick_max_ms", stats.tick_max_ms),
        ("deadline_misses", stats.deadline_misses),
        ("deadline_misses_per_s", misses_per_s),
        ("rtf", stats.rtf),
        ("ticks", stats.ticks),
        ("last_tick_age_ms", (tick_age_s or 0.0) * 1e3),
    )
    if realtime and tick_age_s is not None and tick_age_s > limits.control_stale_s:
        return DiagnosticStatus(
            "control/loop",
            Level.ERROR,
            f"control loop stale: no tick for {tick_age_s:.2f} s",
            values=values,
            stops_motion=True,
        )
    problems = []
    if realtime and stats.tick_p99_ms > limits.tick_p99_warn_fraction * period_ms:  # headless: no deadline
        problems.append(f"tick p99 {stats.tick_p99_ms:.1f} ms of a {period_ms:.0f} ms period")
    if realtime and stats.ticks > stats.control_hz * 2 and stats.rtf < limits.rtf_warn:
        problems.append(f"real-time factor {stats.rtf:.2f}")
    if realtime and misses_per_s > limits.deadline_misses_warn_per_s:
        problems.append(f"{misses_per_s:.1f} deadline misses/s")
    if problems:
        return DiagnosticStatus("control/loop", Level.WARN, "; ".join(problems), values=values)
    return DiagnosticStatus(
        "control/loop", Level.OK, f"{stats.control_hz:.0f} Hz, tick p99 {stats.tick_p99_ms:.1f} ms", values=values
    )


def gait_status(late_plans: int, late_s: float, window_s: float, limits: Thresholds) -> DiagnosticStatus:
    """The walk's plans over the last `window_s` (real time): `late_plans` came after they were due, late by
    `late_s` in all. A late plan is walked on the last one's steps: often, the walk follows its commands late and
    a busy machine is the reason (the gait planner's process is short of CPU)."""
    per_s = late_plans / window_s if window_s > 0 else 0.0
    mean_ms = late_s / late_plans * 1e3 if late_plans else 0.0
    values = (("late_plans", late_plans), ("late_plans_per_s", per_s), ("mean_late_ms", mean_ms))
    if per_s > limits.late_walk_plans_warn_per_s:
        message = (
            f"{late_plans} walk plans came late in {window_s:.0f} s (by {mean_ms:.0f} ms on average): "
            "the gait planner is short of CPU"
        )
        return DiagnosticStatus("control/gait", Level.WARN, message, values=values)
    return DiagnosticStatus("control/gait", Level.OK, "walk plans on time", values=values)


def servo_statuses(
    names: Sequence[str],
    readings: ServoReadings,
    limits: Thresholds,
    hardware_ids: Sequence[str] | None = None,
    lost: Collection[str] = (),
) -> list[DiagnosticStatus]:
    """One status per servo. Overheating, overload and a bad supply stop the robot; so does any hardware error bit
    (the servo has cut its own torque)."""
    statuses = []
    for i, name in enumerate(names):
        temperature = float(readings.temperature_c[i])
        load = float(readings.load_pct[i])
        error = abs(float(readings.position_error_rad[i]))
        bits = HardwareError(int(readings.error_bits[i]))
        values = (
            ("temperature_c", round(temperature, 2)),
            ("current_a", round(float(readings.current_a[i]), 3)),
            ("voltage_v", round(float(readings.voltage_v[i]), 2)),
            ("load_pct", round(load, 1)),
            ("position_error_rad", round(error, 4)),
            ("hardware_error", int(bits)),
            ("hardware_error_text", bits.describe()),
        )
        hardware_id = hardware_ids[i] if hardware_ids else f"XM430-W350 #{i + 1}"
        if name in lost:
            level, message = Level.ERROR, "not answering on the bus"
        elif bits:
            level, message = Level.ERROR, f"hardware error: {bits.describe()}"
        elif temperature >= limits.servo_temperature_error_c:
            level, message = (
                Level.ERROR,
                f"overheating: {temperature:.0f} C (limit {limits.servo_temperature_error_c:g})",
            )
        elif temperature >= limits.servo_temperature_warn_c:
            level, message = Level.WARN, f"hot: {temperature:.0f} C"
        elif load >= limits.servo_load_warn_pct:
            level, message = Level.WARN, f"heavily loaded: {load:.0f} % of stall torque"
        elif error >= limits.servo_position_error_warn_rad:
            level, message = Level.WARN, f"position error {np.degrees(error):.0f} deg"
        else:
            level, message = Level.OK, f"{temperature:.0f} C, {load:.0f} % load"
        statuses.append(
            DiagnosticStatus(f"servos/{name}", level, message, hardware_id, values, stops_motion=level == Level.ERROR)
        )
    return statuses


def power_status(power: PowerState | None, cells: int, limits: Thresholds) -> DiagnosticStatus:
    """The pack: low charge or a sagging voltage is an alarm (the operator lands the robot), not a stop."""
    if power is None:
        return DiagnosticStatus("power/battery", Level.STALE, "no battery reading")
    cell_v = power.voltage_v / cells
    values = (
        ("voltage_v", round(power.voltage_v, 3)),
        ("cell_voltage_v", round(cell_v, 3)),
        ("current_a", round(power.current_a, 3)),
        ("power_w", round(power.power_w, 2)),
        ("state_of_charge_pct", round(power.soc * 100.0, 2)),
    )
    summary = f"{power.voltage_v:.1f} V, {power.soc * 100:.0f} %"
    if power.soc <= limits.battery_error_soc or cell_v <= limits.battery_error_cell_v:
        return DiagnosticStatus(
            "power/battery", Level.ERROR, f"battery critical: {summary}; land the robot now", "6S LiPo", values
        )
    if power.soc <= limits.battery_warn_soc or cell_v <= limits.battery_warn_cell_v:
        return DiagnosticStatus("power/battery", Level.WARN, f"battery low: {summary}", "6S LiPo", values)
    return DiagnosticStatus("power/battery", Level.OK, summary, "6S LiPo", values)


def sensor_statuses(
    perception: PerceptionState | None,
    sim_time_s: float,
    camera_sim_s: float | None,
    lidar_sim_s: float | None,
    imu_age_s: float,
    nominal_hz: float,
    limits: Thresholds,
) -> list[DiagnosticStatus]:
    """Camera and lidar: rate and staleness in simulated time (STALE when their data stopped). The IMU: a lost IMU
    is an ERROR that stops the robot, since balancing needs it."""
    statuses = []
    if imu_age_s > limits.imu_stale_s:
        statuses.append(
            DiagnosticStatus(
                "sensors/imu",
                Level.ERROR,
                f"IMU lost: no sample for {imu_age_s:.2f} s",
                values=(("age_s", round(imu_age_s, 3)),),
                stops_motion=True,
            )
        )
    else:
        statuses.append(
            DiagnosticStatus("sensors/imu", Level.OK, "sampling every tick", values=(("age_s", round(imu_age_s, 3)),))
        )
    if perception is None:
        return statuses
    for name, hz, last, stale_s in (
        ("camera", perception.camera_hz, camera_sim_s, limits.camera_stale_s),
        ("lidar", perception.lidar_hz, lidar_sim_s, limits.lidar_stale_s),
    ):
        age = None if last is None else max(0.0, sim_time_s - last)
        values = (("rate_hz", hz), ("nominal_hz", nominal_hz), ("age_s", round(age, 3) if age is not None else -1.0))
        if perception.status.startswith("error"):
            level, message = Level.ERROR, perception.status
        elif perception.status == "starting" or age is None:
            level, message = Level.OK, "starting"
        elif age > stale_s:
            level, message = Level.STALE, f"no {name} data for {age:.1f} s"
        elif sim_time_s > RATE_SETTLED_S and hz < limits.sensor_rate_warn_fraction * nominal_hz:
            level, message = Level.WARN, f"{hz:.1f} Hz of {nominal_hz:g}"
        else:
            level, message = Level.OK, f"{hz:.1f} Hz"
        statuses.append(DiagnosticStatus(f"sensors/{name}", level, message, values=values))
    return statuses
