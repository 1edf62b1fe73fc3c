"""`humanoid hil`: the hardware-in-the-loop rig from the command line. It runs the simulated robot behind the
emulated servo bus and sensor boards until stopped, and writes the robot configuration that points the real-robot
backend at it (`humanoid serve --backend dynamixel --robot-config ...`)."""

from __future__ import annotations

import argparse
import signal
import sys
import threading
from pathlib import Path

from app.settings import Settings


def _hil(args: argparse.Namespace, settings: Settings) -> int:
    from robot.hardware.config import ConfigError, load_config, save_config
    from robot.hil.rig import HilRig, rig_config
    from robot.model.world import generate_world

    try:
        base = load_config(Path(args.config)) if args.config else None
    except (ConfigError, OSError) as exc:
        print(f"cannot read {args.config}: {exc}", file=sys.stderr)
        return 2
    config = rig_config(base, lockstep=args.lockstep)
    out = Path(args.write_config) if args.write_config else Path(settings.data_dir) / "hil-robot.toml"
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    with HilRig(generate_world(args.seed), config, lockstep=args.lockstep) as rig:
        out.parent.mkdir(parents=True, exist_ok=True)
        save_config(rig.robot_config(), out)
        pace = "one control period per tick of the robot" if args.lockstep else "real time"
        print(
            f"rig up (seed {args.seed}, physics in {pace}): servo bus {rig.port_name} with the OpenCR IMU and FSR "
            f"feet, lidar {rig.devices['lidar']}, camera stream {rig.devices['camera']}",
            flush=True,
        )
        print(f"its robot configuration: {out}", flush=True)
        if rig.robot_config().camera == "none":
            print("no camera: the robot's RealSense driver needs the realsense extra (pip install '.[realsense]')")
        print(f"drive it: humanoid serve --backend dynamixel --robot-config {out} --seed {args.seed}", flush=True)
        stop.wait(args.duration if args.duration > 0 else None)
        truth = rig.truth()
    x, y, _ = truth.base_position
    fell = "fallen" if truth.fallen else "upright"
    print(f"rig stopped after {truth.sim_time_s:.1f} s of physics: robot at ({x:.2f}, {y:.2f}), {fell}")
    return 0


def add_hil_parser(sub: argparse._SubParsersAction) -> None:
    hil = sub.add_parser(
        "hil",
        help="the hardware-in-the-loop rig: the simulated robot behind emulated Dynamixel servos and sensor boards",
    )
    hil.add_argument("--seed", type=int, default=0, help="world seed (serve the robot with the same one)")
    hil.add_argument("--config", default=None, help="the robot configuration to wire the rig as (default: humanoid_v1)")
    hil.add_argument(
        "--write-config",
        default=None,
        help="where to write the configuration that points the real-robot backend at the rig (default: "
        "hil-robot.toml in the data directory)",
    )
    hil.add_argument(
        "--lockstep",
        action="store_true",
        help="the physics moves one control period per tick of the robot instead of with the clock (a shared or "
        "slow machine: slower, but the same physics)",
    )
    hil.add_argument("--duration", type=float, default=0.0, help="stop after this many seconds (0: until Ctrl-C)")
    hil.set_defaults(func=_hil)
