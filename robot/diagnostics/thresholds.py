"""Where OK ends and WARN or ERROR begin. Plain values: the settings fill them and they cross to the worker."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Thresholds:
    # compute (averaged over the last few 1 s samples, so a short burst is not an alarm)
    cpu_warn_pct: float = 90.0
    memory_warn_pct: float = 90.0
    memory_error_pct: float = 97.0
    disk_warn_pct: float = 90.0
    disk_error_pct: float = 98.0
    cpu_temperature_warn_c: float = 85.0
    # control loop
    tick_p99_warn_fraction: float = 0.8  # of the control period
    rtf_warn: float = 0.95
    deadline_misses_warn_per_s: float = 1.0
    control_stale_s: float = 0.5  # no tick for this long (50 periods at 100 Hz): ERROR, safe stop
    late_walk_plans_warn_per_s: float = 2.0  # of the walk's ten plans a second, came after they were due
    # servos (the XM430 shuts itself down at 80 C: the robot stops before it does)
    servo_temperature_warn_c: float = 65.0
    servo_temperature_error_c: float = 75.0
    servo_load_warn_pct: float = 80.0
    servo_position_error_warn_rad: float = 0.3
    # power: the 6S pack
    battery_warn_soc: float = 0.20
    battery_error_soc: float = 0.10
    battery_warn_cell_v: float = 3.5  # under load
    battery_error_cell_v: float = 3.3
    # sensors
    camera_stale_s: float = 1.0
    lidar_stale_s: float = 1.0
    imu_stale_s: float = 0.05  # the balance controller cannot work without it: ERROR, safe stop
    sensor_rate_warn_fraction: float = 0.8  # of the nominal rate
    # links
    link_check_period_s: float = 30.0
    link_timeout_s: float = 2.0
