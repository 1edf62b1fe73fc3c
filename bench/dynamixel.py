"""`humanoid bench dynamixel`: the real-robot backend's bus loop against the Protocol 2.0 emulator, which takes the
time the bytes would take on the wire at each baud rate (24 XM430s, the emulator in its own process).

Per baud rate (1, 2 (the default) and 4 Mbps) and way of reading (Fast Sync Read, the default, and plain sync read):
- flat out: ticks per second of a tick as the backend does it (sync write of the goals, sync read of current,
  velocity and position, the slow blocks in turn), and the tick time p50/p99;
- at the control rate (100 Hz): the share of each period the bus was busy, measured by the emulator (bytes both
  ways at the baud rate), next to the budget the backend computes at start-up;
- a servo that stops answering: ticks until it is declared lost.

At 2 Mbps with Fast Sync Read, once more with the OP3's sensor boards on the bus (the OpenCR at ID 200, the FSR
feet at 111 and 112), read each tick by one bulk read after the servos (`sensor_read_ms`: that read's time).
"""

from __future__ import annotations

import dataclasses
import time
from typing import Any

import numpy as np

TARGETS = {"loop_hz": 100.0}


def _stats(values: list[float]) -> dict[str, float]:
    data = np.asarray(values, dtype=float)
    return {
        "p50": round(float(np.percentile(data, 50)), 3),
        "p99": round(float(np.percentile(data, 99)), 3),
        "max": round(float(data.max()), 3),
    }


def _one_rate(baudrate: int, seconds: float, fast: bool, sensors: bool = False) -> dict[str, Any]:
    from robot.control.priority import raise_thread_priority
    from robot.hardware.bus import DynamixelBus
    from robot.hardware.bus_emulator import BusEmulator
    from robot.hardware.bus_sensors import BusSensors
    from robot.hardware.config import default_config

    config = dataclasses.replace(default_config(baudrate=baudrate), reply_margin_ms=20.0, fast_sync_read=fast)
    ids = [j.servo_id for j in config.joints]
    with BusEmulator(ids, baudrate=baudrate, wire_time=True, sensors=sensors) as emulator:
        bus = DynamixelBus(dataclasses.replace(config, port=emulator.port_name))
        boards = BusSensors(bus.port, bus.packets, imu=sensors, feet=sensors)
        raise_thread_priority()  # as the backend's control loop runs (real time where allowed)
        bus.open()
        try:
            bus.prepare()  # as the backend starts: no return delay
            bus.set_torque(True)
            boards.probe()
            goals = np.zeros(len(config.joints))
            ticks: list[float] = []
            sensor_reads: list[float] = []
            started = time.perf_counter()
            while time.perf_counter() - started < seconds:
                t0 = time.perf_counter()
                bus.write_goals(goals)
                bus.read()
                if bus.slow_due:  # the monitoring blocks in turn, as the backend reads them after a tick
                    bus.read_slow()
                if sensors:
                    t1 = time.perf_counter()
                    boards.read()
                    sensor_reads.append((time.perf_counter() - t1) * 1e3)
                ticks.append((time.perf_counter() - t0) * 1e3)
            flat_hz = len(ticks) / (time.perf_counter() - started)
            busy0, wall0 = emulator.stats().busy_s, time.perf_counter()
            period = 1.0 / config.control_hz
            next_tick = time.perf_counter()
            paced = 0
            while time.perf_counter() - wall0 < seconds:
                next_tick += period
                bus.write_goals(goals)
                bus.read()
                boards.read()
                if bus.slow_due:
                    bus.read_slow()
                paced += 1
                time.sleep(max(0.0, next_tick - time.perf_counter()))
            busy = (emulator.stats().busy_s - busy0) / (time.perf_counter() - wall0)
            paced_hz = paced / (time.perf_counter() - wall0)
            emulator.set_fault(13, dead=True)
            lost_after = 0
            while "r_knee" not in bus.read().lost:
                lost_after += 1
            budget = bus.budget(boards.wire_bytes(), 0 if boards.empty else 1)
            return {
                "baudrate": baudrate,
                "sync_read": "fast" if fast else "plain",
                "servos": len(config.joints),
                "sensor_boards": len(boards.boards),
                "sensor_read_ms": _stats(sensor_reads) if sensor_reads else None,
                "flat_out_hz": round(flat_hz, 1),
                "tick_ms": _stats(ticks),
                "paced_hz": round(paced_hz, 1),
                "bus_busy_measured": round(busy, 3),
                "bus_budget": {
                    "bytes_per_tick": budget.bytes_per_tick,
                    "wire_ms": round(budget.wire_ms_per_tick, 3),
                    "utilisation": round(budget.utilisation, 3),
                    "fits": budget.fits,
                },
                "dead_servo_lost_after_ticks": lost_after + 1,
                "met": flat_hz >= TARGETS["loop_hz"],
            }
        finally:
            bus.close()


BAUDRATES = (1_000_000, 2_000_000, 4_000_000)


def run_dynamixel(seconds: float = 10.0, baudrates: tuple[int, ...] = BAUDRATES) -> dict[str, Any]:
    started = time.perf_counter()
    rates = [_one_rate(b, seconds, fast) for b in baudrates for fast in (True, False)]
    default = [r for r in rates if r["sync_read"] == "fast"]
    with_sensors = _one_rate(2_000_000, seconds, True, sensors=True)
    return {
        "suite": "dynamixel",
        "seconds_per_phase": seconds,
        "rates": rates,
        "with_sensor_boards": with_sensors,
        "bars": {
            "loop_hz": {
                "target": TARGETS["loop_hz"],
                "measured": {r["baudrate"]: r["flat_out_hz"] for r in default},
                "met": all(r["met"] for r in default),
            }
        },
        "wall_s": round(time.perf_counter() - started, 1),
    }
