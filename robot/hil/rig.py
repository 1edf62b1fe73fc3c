"""The hardware-in-the-loop rig: the simulated robot in its world (MuJoCo) behind the byte-level emulators of its
devices, so the real-robot code (`serve --backend dynamixel`) runs unchanged against physics.

On its servo bus (a pseudo-terminal the Dynamixel SDK opens as it would the U2D2): the 24 XM430s, whose goal
positions drive the simulated joints and whose present position, velocity and current come from them, the OpenCR
(ID 200) whose IMU registers hold the simulated trunk's, and the two FSR foot modules. On its own pseudo-terminal,
an LD06 lidar whose turns are cast in the simulated world; on a Unix socket, the head camera's RGB-D frames (the
robot's RealSense driver reads them through librealsense's software device). The robot hangs on its stand,
unmoving, until torque first comes on (as a real one is held while it is switched on).
"""

from __future__ import annotations

import contextlib
import importlib.util
import multiprocessing as mp
import os
import shutil
import sys
import tempfile
from collections.abc import Callable
from dataclasses import replace
from multiprocessing.connection import Connection
from typing import Any

from robot.diagnostics.thresholds import Thresholds
from robot.hardware import control_table as ct
from robot.hardware import fsr
from robot.hardware.bus_emulator import BusEmulator, EmulatedBus, EmulatedXM430, serve_bus
from robot.hardware.config import HardwareConfig, default_config
from robot.hardware.sensor_emulators import EmulatedFSR, EmulatedOpenCR
from robot.hil.plant import LockstepPhysics, RealTimePhysics, RigPlant, RigTruth
from robot.hil.sensors import SceneShare, serve_sensors
from robot.model.world import WorldLayout

GIL_SWITCH_S = 0.0005
SENSORS_START_S = 60.0  # the sensors' process builds its scene and its camera's renderer
# The host waits this long past a reply's wire time: the rig's devices answer from a process that shares the
# host's cores (and between physics blocks), not within the microseconds of real servos.
RIG_REPLY_MARGIN_MS = 10.0
# In lockstep the physics waits for the robot, so a late reply costs wall time only: the host waits long enough
# that its own process or the rig's, paused by a busy machine, is not taken for a servo that stopped answering.
# (At 250 ms, a full test run on two cores once lost the OpenCR: three replies in a row came later than that.)
LOCKSTEP_REPLY_MARGIN_MS = 1000.0
# For the same reason, in lockstep the watchdogs that count wall time (a stalled control loop, a sensor that
# stopped, the servos' bus watchdog) allow what a busy machine takes: a robot process paused for a second stops
# nothing in the rig's world. (A run with one core kept busy once stopped safely at a 0.5 s pause.) In real time
# the robot's own limits stand: those runs measure what the real robot would live through.
LOCKSTEP_STALE_S = 5.0
LOCKSTEP_BUS_WATCHDOG_MS = 127 * ct.BUS_WATCHDOG_UNIT_MS  # the longest the servos' register holds (2.54 s)


def rig_config(base: HardwareConfig | None = None, lockstep: bool = False) -> HardwareConfig:
    """The robot's configuration as the rig wires it: every servo of `base` (default: humanoid_v1's), the OpenCR's
    IMU and the FSR feet on the bus, and replies waited for as long as the rig may take (paced in `lockstep` or
    not)."""
    config = base or default_config()
    margin = LOCKSTEP_REPLY_MARGIN_MS if lockstep else RIG_REPLY_MARGIN_MS
    config = replace(config, imu="opencr", feet="fsr", reply_margin_ms=max(config.reply_margin_ms, margin))
    if lockstep and config.bus_watchdog_ms:
        config = replace(config, bus_watchdog_ms=max(config.bus_watchdog_ms, LOCKSTEP_BUS_WATCHDOG_MS))
    return config


def rig_thresholds(base: Thresholds | None = None, lockstep: bool = False) -> Thresholds:
    """The diagnostics' limits for a robot on the rig: `base`'s (default: the robot's own), with the wall-clock
    staleness limits of `LOCKSTEP_STALE_S` in lockstep."""
    limits = base or Thresholds()
    if not lockstep:
        return limits
    return replace(
        limits,
        control_stale_s=max(limits.control_stale_s, LOCKSTEP_STALE_S),
        imu_stale_s=max(limits.imu_stale_s, LOCKSTEP_STALE_S),
        camera_stale_s=max(limits.camera_stale_s, LOCKSTEP_STALE_S),
        lidar_stale_s=max(limits.lidar_stale_s, LOCKSTEP_STALE_S),
    )


class HilRig(BusEmulator):
    """The rig in its own process (the physics and the bus answer whatever the robot's process does). Use as a
    context manager; `port_name` is the servo bus's device, for `HardwareConfig.port`."""

    def __init__(
        self,
        layout: WorldLayout,
        config: HardwareConfig | None = None,
        baudrate: int | None = None,
        wire_time: bool = True,
        lockstep: bool = False,
    ) -> None:
        """`layout`: the world the robot is in (serve the robot with the same one, e.g. the same seed);
        `config`: the robot's wiring (servo IDs, directions, offsets: the rig's servos are wired as it says);
        `wire_time`: each packet takes its time on the wire at `baudrate` (default: the config's); `lockstep`: the
        physics moves one control period per tick of the host (`LockstepPhysics`), not with the wall clock."""
        self.config = config or default_config()
        self.layout = layout
        self.lockstep = lockstep
        self.devices: dict[str, str] = {}  # the other devices' ports, once started
        super().__init__(
            [j.servo_id for j in self.config.joints], baudrate or self.config.baudrate, wire_time, sensors=True
        )

    daemon_process = False  # it starts the sensors' process; `stop` (or leaving the `with`) ends both
    # It builds the simulated world first: on a machine whose cache is cold (its first run), simplifying the
    # meshes takes a minute or more on two busy cores (30 s was too short once: "the bus emulator did not start").
    start_timeout_s = 600.0

    def _child(self) -> tuple[Callable[..., None], tuple]:
        return _serve_rig, (self.layout, self.config, self.baudrate, self.wire_time, self.lockstep)

    def start(self) -> None:
        super().start()
        self.devices = self._call("devices")

    def robot_config(self) -> HardwareConfig:
        """The robot's configuration pointed at the rig: its servo bus, the lidar's port and the camera's stream
        (no camera without the `realsense` extra, whose driver reads it)."""
        devices = self.devices
        lidar = f"ld06:{devices['lidar']}"
        camera = f"rig:{devices['camera']}" if importlib.util.find_spec("pyrealsense2") is not None else "none"
        return replace(self.config, port=self.port_name, lidar=lidar, camera=camera)

    def truth(self) -> RigTruth:
        """Where the robot really is and whether it fell, where the objects are (for judging a run)."""
        return self._call("truth")


def _serve_rig(
    conn: Connection, layout: WorldLayout, config: HardwareConfig, baudrate: int, wire_time: bool, lockstep: bool
) -> None:
    from robot.sim.backend import MujocoSimBackend  # the child's own: a spawned process starts bare

    # The bus's thread answers the robot's packets; the requests' thread shares the interpreter with it. By default
    # a thread waits up to 5 ms for another to give the interpreter up: a reply late enough that the robot's reads
    # time out (the camera's thread was here once, and a pick of 20 lost its IMU for 0.24 s).
    sys.setswitchinterval(GIL_SWITCH_S)

    backend = MujocoSimBackend(layout)
    standing = backend.read().joint_positions
    names = list(backend.joint_names)
    servos = {
        j.servo_id: EmulatedXM430(j.servo_id, j.to_servo_rad(float(standing[names.index(j.joint)])))
        for j in config.joints
    }
    imu = EmulatedOpenCR()
    feet = {"left": EmulatedFSR(fsr.LEFT_FSR_ID), "right": EmulatedFSR(fsr.RIGHT_FSR_ID)}
    bus = EmulatedBus([*servos.values(), imu, *feet.values()], baudrate, wire_time)
    plant = RigPlant(backend, config, servos, imu, feet)
    physics = (
        LockstepPhysics(plant, 1.0 / config.control_hz) if lockstep else RealTimePhysics(plant, backend.physics_dt)
    )
    bus.attach(physics)

    # the lidar and the camera in a process of their own (see robot.hil.sensors), fed the scene's pose
    context = mp.get_context("spawn")
    model = backend.model
    share = SceneShare(model.nq, model.nmocap)
    plant.scene_out = share.write
    with bus.lock:
        plant.report()
    folder = tempfile.mkdtemp(prefix="humanoid-rig-")
    here, there = context.Pipe()
    sensors = context.Process(
        target=serve_sensors,
        args=(there, layout, share.name, os.path.join(folder, "camera.sock")),
        name="rig-sensors",
        daemon=True,
    )
    sensors.start()
    there.close()
    devices = here.recv() if here.poll(SENSORS_START_S) else {}

    def answer(request: tuple) -> Any:
        if request[0] == "truth":
            return plant.truth(physics.late_blocks)
        if request[0] == "devices":
            if not devices:
                raise RuntimeError("the rig's lidar and camera did not start")
            return devices
        return bus.control(request)

    try:
        serve_bus(conn, bus, answer)
    finally:
        with contextlib.suppress(OSError):
            here.send("stop")
        sensors.join(timeout=5)
        if sensors.is_alive():
            sensors.kill()
        share.close(unlink=True)
        shutil.rmtree(folder, ignore_errors=True)
