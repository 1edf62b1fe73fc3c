"""`humanoid hardware init-config | check | calibrate`: the real robot's servos, from the command line."""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
from pathlib import Path
from typing import Any

from app.settings import Settings
from robot.hardware.config import HardwareConfig


def _config(args: argparse.Namespace, settings: Settings) -> HardwareConfig:
    config = settings.model_copy(update={"robot_config": args.config or settings.robot_config}).hardware_config()
    if args.port:
        config = dataclasses.replace(config, port=args.port)
    if getattr(args, "baud", None):
        config = dataclasses.replace(config, baudrate=args.baud)
    return config


def _init_config(args: argparse.Namespace, settings: Settings) -> int:
    from robot.hardware.config import default_config, save_config

    path = Path(args.config or settings.robot_config)
    if path.exists() and not args.force:
        print(f"{path} exists; --force to overwrite it", file=sys.stderr)
        return 1
    save_config(default_config(port=args.port or "/dev/ttyUSB0"), path)
    print(f"wrote {path}: humanoid_v1's 24 joints on servo IDs 1-24; edit directions, then run calibrate")
    return 0


def _check(args: argparse.Namespace, settings: Settings) -> int:
    """Ping every configured servo: model, firmware, latched hardware errors; the sensor boards the configuration
    puts on the bus (the OpenCR's IMU, the FSR feet), with one reading each; and the control tick's bus budget."""
    from robot.hardware.bus import BusError, DynamixelBus
    from robot.hardware.bus_sensors import BusSensors
    from robot.hardware.control_table import XM430_W350_MODEL
    from robot.hardware.xm430 import HardwareError

    config = _config(args, settings)
    bus = DynamixelBus(config)
    boards = BusSensors(bus.port, bus.packets, imu=config.imu == "opencr", feet=config.feet == "fsr")
    budget = bus.budget(boards.wire_bytes(), 0 if boards.empty else 1)
    try:
        bus.open()
        servos = bus.ping_all()
        missing_boards = boards.probe()
        sensed = boards.read()
    except BusError as exc:
        print(f"cannot check {config.port}: {exc}", file=sys.stderr)
        return 2
    finally:
        bus.close()
    rows = [
        {
            "joint": s.joint,
            "id": s.servo_id,
            "model": s.model,
            "firmware": s.firmware,
            "hardware_error": HardwareError(s.hardware_error).describe() if s.model is not None else None,
            "ok": s.model == XM430_W350_MODEL and not s.hardware_error,
        }
        for s in servos
    ]
    report = {
        "port": config.port,
        "baudrate": config.baudrate,
        "servos": rows,
        "answered": sum(r["model"] is not None for r in rows),
        "expected": len(rows),
        "bus_utilisation": round(budget.utilisation, 3),
        "bytes_per_tick": budget.bytes_per_tick,
        "fits": budget.fits,
        "sensor_boards": [
            {"name": b.name, "id": b.device_id, "found": not any(b.name in m for m in missing_boards)}
            for b in boards.boards
        ],
        "imu_tilt_deg": round(_tilt_deg(sensed.imu.quat), 1) if sensed.imu is not None else None,
        "foot_forces_n": [[round(float(f), 2) for f in foot] for foot in sensed.feet] if config.feet == "fsr" else None,
    }
    if args.json:
        print(json.dumps(report, indent=2))
    else:
        for r in rows:
            state = "missing" if r["model"] is None else f"model {r['model']} fw {r['firmware']}: {r['hardware_error']}"
            print(f"{r['id']:>3} {r['joint']:<12} {state}")
        for board in report["sensor_boards"]:
            print(f"{board['id']:>3} {board['name']:<16} {'found' if board['found'] else 'missing'}")
        if report["imu_tilt_deg"] is not None:
            print(f"IMU tilt {report['imu_tilt_deg']} deg (stand the robot upright: it should be near 0)")
        print(
            f"{report['answered']}/{report['expected']} answered; the control tick uses "
            f"{budget.utilisation:.0%} of the bus at {config.baudrate} baud"
        )
    return 0 if all(r["ok"] for r in rows) and not missing_boards else 1


def _tilt_deg(quat: Any) -> float:
    """The trunk's tilt from upright (what the fall check compares with its threshold)."""
    from robot.sensors.imu import rpy_from_quat

    roll, pitch, _ = rpy_from_quat(quat)
    return math.degrees(math.acos(max(-1.0, min(1.0, math.cos(roll) * math.cos(pitch)))))


def _calibrate(args: argparse.Namespace, settings: Settings) -> int:
    """Torque off; the operator holds the robot in its zero pose (every joint at 0: arms and legs straight down,
    head forward, grippers closed); each servo's angle then is its joint's zero offset, saved to the file."""
    from robot.hardware.bus import BusError, DynamixelBus
    from robot.hardware.config import save_config

    config = _config(args, settings)
    bus = DynamixelBus(config.with_offsets({j.joint: 0.0 for j in config.joints}))
    try:
        bus.open()
        bus.set_torque(False)
        if not args.yes:
            input("Torque is off. Hold the robot in its zero pose, then press Enter... ")
        reading = bus.read()
    except BusError as exc:
        print(f"cannot calibrate on {config.port}: {exc}", file=sys.stderr)
        return 2
    finally:
        bus.close()
    if reading.lost or reading.failed_reads:
        print("not every servo answered; nothing saved", file=sys.stderr)
        return 1
    # with zero offsets the bus reports direction * servo angle / scale: the servo angle is what the offset must be
    offsets = {j.joint: float(reading.positions[i]) * j.direction * j.scale for i, j in enumerate(config.joints)}
    path = Path(args.config or settings.robot_config)
    save_config(config.with_offsets(offsets), path)
    print(json.dumps({"saved": str(path), "offsets_rad": {k: round(v, 4) for k, v in offsets.items()}}, indent=2))
    return 0


def add_hardware_parser(sub: argparse._SubParsersAction) -> None:
    hardware = sub.add_parser("hardware", help="the real robot's Dynamixel servos: config, check, calibrate")
    commands = hardware.add_subparsers(dest="hardware_command", required=True)
    for name, func, help_text in (
        ("init-config", _init_config, "write the humanoid_v1 robot configuration file"),
        ("check", _check, "ping every servo: model, firmware, errors; and the bus budget"),
        ("calibrate", _calibrate, "record each joint's zero offset (robot held in its zero pose, torque off)"),
    ):
        command = commands.add_parser(name, help=help_text)
        command.add_argument("--config", default=None, help="robot configuration file (HUMANOID_ROBOT_CONFIG)")
        command.add_argument("--port", default=None, help="serial device, e.g. /dev/ttyUSB0")
        if name == "check":
            command.add_argument("--baud", type=int, default=None, help="baud rate (default: the file's)")
            command.add_argument("--json", action="store_true")
        if name == "init-config":
            command.add_argument("--force", action="store_true", help="overwrite an existing file")
        if name == "calibrate":
            command.add_argument("--yes", action="store_true", help="do not wait for Enter (the robot is in place)")
        command.set_defaults(func=func)
