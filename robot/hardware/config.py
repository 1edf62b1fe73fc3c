"""The real robot's configuration file (TOML): the bus, and for each joint its servo ID, direction, zero offset,
gear scale and limits. `default_config()` is the humanoid_v1 wiring (the OP3's IDs 1-20, then the wrists and
grippers 21-24); `humanoid hardware calibrate` records the zero offsets into the file.

    [bus]
    port = "/dev/ttyUSB0"
    baudrate = 2000000
    latency_timer_ms = 1      # the U2D2's FTDI latency timer (set to 1 ms by a udev rule)
    control_hz = 100
    fast_sync_read = true     # one reply packet for all servos (firmware 45+); false: a reply from each servo
    bus_watchdog_ms = 500     # a servo that hears nothing this long stops where it is (0: off)

    [sensors]                 # each may be "none" (see docs/real-robot-sensors.md)
    imu = "opencr"            # the OpenCR at ID 200 on the servo bus, or "bno055:/dev/ttyUSB1" (its UART)
    feet = "fsr"              # the FSR foot modules at IDs 111 (right) and 112 (left) on the servo bus
    camera = "0"              # an OpenCV device index, a path or stream URL, "realsense", or "rig:PATH" (the HIL rig)
    lidar = "ld06:/dev/ttyUSB2"   # an LDRobot LD06 or LD19 on its serial port

    [joints.r_knee]
    id = 13
    direction = -1            # +1 when the servo turns the joint's positive way
    offset_rad = 0.012        # servo angle (from its centre, 2048) when the joint is at zero
    scale = 1.0               # servo radians per joint unit (rad, or m for a gripper's finger)
    min = -2.5
    max = 0.05
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path

from robot.hardware import control_table as ct
from robot.model import humanoid_v1

# The OP3's servo IDs (Robotis' numbering), then the arm extras of humanoid_v1.
OP3_IDS = {
    "r_sho_pitch": 1, "l_sho_pitch": 2, "r_sho_roll": 3, "l_sho_roll": 4, "r_el": 5, "l_el": 6,
    "r_hip_yaw": 7, "l_hip_yaw": 8, "r_hip_roll": 9, "l_hip_roll": 10, "r_hip_pitch": 11, "l_hip_pitch": 12,
    "r_knee": 13, "l_knee": 14, "r_ank_pitch": 15, "l_ank_pitch": 16, "r_ank_roll": 17, "l_ank_roll": 18,
    "head_pan": 19, "head_tilt": 20, "r_wrist": 21, "l_wrist": 22, "r_grip": 23, "l_grip": 24,
}  # fmt: skip
GRIPPER_SERVO_RAD = 2.4  # servo travel from closed to fully open fingers
SUPPORTED_BAUD = (57_600, 115_200, 1_000_000, 2_000_000, 3_000_000, 4_000_000)


class ConfigError(ValueError):
    pass


@dataclass(frozen=True)
class JointServo:
    joint: str
    servo_id: int
    direction: int = 1
    offset_rad: float = 0.0
    scale: float = 1.0
    lower: float = -math.pi
    upper: float = math.pi

    def to_servo_rad(self, joint_value: float) -> float:
        return self.direction * joint_value * self.scale + self.offset_rad

    def to_joint(self, servo_rad: float) -> float:
        return (servo_rad - self.offset_rad) / (self.direction * self.scale)

    def to_ticks(self, joint_value: float) -> int:
        return round(self.to_servo_rad(joint_value) * ct.POSITION_PER_RAD + ct.POSITION_CENTRE)

    def from_ticks(self, ticks: int) -> float:
        return self.to_joint((ticks - ct.POSITION_CENTRE) / ct.POSITION_PER_RAD)

    def clamp(self, joint_value: float) -> float:
        return min(self.upper, max(self.lower, joint_value))


@dataclass(frozen=True)
class HardwareConfig:
    port: str = "/dev/ttyUSB0"
    baudrate: int = 2_000_000  # 24 servos at 100 Hz fill ~87 % of a 1 Mbps bus, ~50 % at 2 Mbps
    latency_timer_ms: float = 1.0
    control_hz: float = 100.0
    # extra wait for a reply beyond its wire time and the USB latency (the SDK's 2 ms); more for a busy host or an
    # emulated bus, whose replies depend on the scheduler
    reply_margin_ms: float = 2.0
    fast_sync_read: bool = True
    # Long enough that a loaded host's hiccup (119 ms measured with Chromium and the test suite on 2 cores) is not
    # taken for a lost host; in position mode a silent host's servos hold their last goal meanwhile.
    bus_watchdog_ms: int = 500
    joints: tuple[JointServo, ...] = field(default_factory=tuple)
    imu: str = "none"  # "opencr", "bno055:<serial port>" or "none"
    feet: str = "none"  # "fsr" or "none"
    camera: str = "none"  # an OpenCV index, path or URL, "realsense", "rig:PATH", or "none"
    lidar: str = "none"  # "ld06:<serial port>", "ld19:<serial port>" or "none"

    def __post_init__(self) -> None:
        ids = [j.servo_id for j in self.joints]
        if len(set(ids)) != len(ids):
            raise ConfigError(f"servo IDs repeat: {sorted(i for i in ids if ids.count(i) > 1)}")
        if self.baudrate not in SUPPORTED_BAUD:
            raise ConfigError(f"baud rate {self.baudrate} is not one the XM430 supports: {SUPPORTED_BAUD}")
        period_ms = 1e3 / self.control_hz
        if self.bus_watchdog_ms and not 3 * period_ms <= self.bus_watchdog_ms <= 127 * ct.BUS_WATCHDOG_UNIT_MS:
            raise ConfigError(
                f"bus_watchdog_ms {self.bus_watchdog_ms} must be 0 (off) or from three control periods "
                f"({3 * period_ms:.0f} ms) to {127 * ct.BUS_WATCHDOG_UNIT_MS} ms"
            )
        if self.imu != "none" and self.imu != "opencr" and not self.imu.startswith("bno055:"):
            raise ConfigError(f"imu {self.imu!r}: use opencr, bno055:<serial port> or none")
        if self.feet not in ("fsr", "none"):
            raise ConfigError(f"feet {self.feet!r}: use fsr or none")
        if self.lidar != "none" and self.lidar.split(":", 1)[0] not in ("ld06", "ld19"):
            raise ConfigError(f"lidar {self.lidar!r}: use ld06:<serial port>, ld19:<serial port> or none")
        for j in self.joints:
            if not 0 <= j.servo_id <= 252:
                raise ConfigError(f"{j.joint}: servo ID {j.servo_id} is outside 0-252")
            if j.direction not in (-1, 1):
                raise ConfigError(f"{j.joint}: direction must be 1 or -1")
            if not (math.isfinite(j.lower) and math.isfinite(j.upper) and j.lower < j.upper):
                raise ConfigError(f"{j.joint}: limits must be finite with min < max")
            if j.scale == 0 or not math.isfinite(j.scale):
                raise ConfigError(f"{j.joint}: scale must be finite and not zero")

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(j.joint for j in self.joints)

    def with_offsets(self, offsets: dict[str, float]) -> HardwareConfig:
        return replace(
            self, joints=tuple(replace(j, offset_rad=offsets.get(j.joint, j.offset_rad)) for j in self.joints)
        )


def default_config(port: str = "/dev/ttyUSB0", baudrate: int = 2_000_000) -> HardwareConfig:
    """humanoid_v1 as built: every joint of the model on its servo, the model's limits, no offsets yet."""
    limits = humanoid_v1.joint_limits()
    joints = []
    for name in humanoid_v1.JOINT_NAMES:
        limit = limits[name]
        scale = GRIPPER_SERVO_RAD / humanoid_v1.FINGER_TRAVEL if name in humanoid_v1.GRIPPER_JOINTS else 1.0
        joints.append(JointServo(name, OP3_IDS[name], 1, 0.0, scale, limit.lower, limit.upper))
    return HardwareConfig(port=port, baudrate=baudrate, joints=tuple(joints))


def load_config(path: str | Path) -> HardwareConfig:
    try:
        data = tomllib.loads(Path(path).read_text())
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise ConfigError(f"cannot read the robot configuration {path}: {exc}") from exc
    bus = data.get("bus", {})
    joints = []
    known = set(humanoid_v1.JOINT_NAMES)
    for name, entry in data.get("joints", {}).items():
        if name not in known:
            raise ConfigError(f"unknown joint {name!r} in {path}; joints: {', '.join(humanoid_v1.JOINT_NAMES)}")
        try:
            joints.append(
                JointServo(
                    name,
                    int(entry["id"]),
                    int(entry.get("direction", 1)),
                    float(entry.get("offset_rad", 0.0)),
                    float(entry.get("scale", 1.0)),
                    float(entry["min"]),
                    float(entry["max"]),
                )
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise ConfigError(f"joint {name} in {path}: {exc!r} (needs id, min, max)") from exc
    missing = [n for n in humanoid_v1.JOINT_NAMES if n not in {j.joint for j in joints}]
    if missing:
        raise ConfigError(f"{path} has no servo for: {', '.join(missing)}")
    order = {n: i for i, n in enumerate(humanoid_v1.JOINT_NAMES)}
    return HardwareConfig(
        port=str(bus.get("port", "/dev/ttyUSB0")),
        baudrate=int(bus.get("baudrate", 2_000_000)),
        latency_timer_ms=float(bus.get("latency_timer_ms", 1.0)),
        control_hz=float(bus.get("control_hz", 100.0)),
        reply_margin_ms=float(bus.get("reply_margin_ms", 2.0)),
        fast_sync_read=bool(bus.get("fast_sync_read", True)),
        bus_watchdog_ms=int(bus.get("bus_watchdog_ms", 500)),
        joints=tuple(sorted(joints, key=lambda j: order[j.joint])),
        **_sensor_entries(data.get("sensors", {})),
    )


def _sensor_entries(sensors: dict[str, object]) -> dict[str, str]:
    unknown = set(sensors) - {"imu", "feet", "camera", "lidar"}
    if unknown:
        raise ConfigError(f"unknown [sensors] entries: {', '.join(sorted(unknown))} (imu, feet, camera, lidar)")
    return {key: str(value) for key, value in sensors.items()}


def dump_config(config: HardwareConfig) -> str:
    lines = [
        "# humanoid_v1 on Dynamixel XM430-W350 servos (see robot/hardware/config.py)",
        "",
        "[bus]",
        f'port = "{config.port}"',
        f"baudrate = {config.baudrate}",
        f"latency_timer_ms = {config.latency_timer_ms!r}",
        f"control_hz = {config.control_hz!r}",
        f"reply_margin_ms = {config.reply_margin_ms!r}",
        f"fast_sync_read = {str(config.fast_sync_read).lower()}",
        f"bus_watchdog_ms = {config.bus_watchdog_ms}",
        "",
        "[sensors]",
        f'imu = "{config.imu}"',
        f'feet = "{config.feet}"',
        f'camera = "{config.camera}"',
        f'lidar = "{config.lidar}"',
    ]
    for j in config.joints:
        lines += [
            "",
            f"[joints.{j.joint}]",
            f"id = {j.servo_id}",
            f"direction = {j.direction}",
            f"offset_rad = {j.offset_rad!r}",
            f"scale = {j.scale!r}",
            f"min = {j.lower!r}",
            f"max = {j.upper!r}",
        ]
    return "\n".join(lines) + "\n"


def save_config(config: HardwareConfig, path: str | Path) -> None:
    Path(path).write_text(dump_config(config))
