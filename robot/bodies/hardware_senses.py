"""What the real robot senses beside its servos: the IMU (the OpenCR's on the servo bus, or a BNO055 on its own
serial port), the feet's force pads (the FSR modules on the servo bus), the head camera and the lidar (their
drivers' threads; the perception service takes their frames). Each may be missing: the body then says what it
lacks, and the core refuses only what needs it (walking, plans).

`read()` runs in the control tick, under the bus lock, right after the servos are read: the boards on the bus in
one bulk read; an IMU on its own port is read by its own thread and only its latest sample is taken here.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, Protocol

import numpy as np

from robot.core.body import Senses
from robot.hardware.bus_sensors import BoardReading, BusSensors
from robot.interface import DiagnosticStatus, Level
from robot.sensors.imu import ImuSample, quat_from_rpy, rpy_from_quat

IMU_STALE_S = 0.1  # an IMU sample older than this is not the robot's orientation any more


class ImuDriver(Protocol):
    """An IMU on its own port (e.g. `robot.sensors.bno055.Bno055Imu`): sampled by its own thread."""

    name: str

    def start(self) -> None: ...

    def stop(self) -> None: ...

    def latest(self) -> ImuSample | None:
        """The newest sample (stamped on the body's clock), None before the first."""

    def problem(self) -> str:
        """Why it gives no samples now ("" when it does)."""


class SensorDriver(Protocol):
    """A camera or a lidar driver (`robot.sensors`): its own thread, its newest frame, what goes wrong."""

    name: str

    def start(self) -> None: ...

    def stop(self) -> None: ...

    def latest(self) -> Any: ...

    def problem(self) -> str: ...


class HardwareSenses:
    """`boards`: the OpenCR and FSR modules to read on the servo bus (None: none); `imu`: an IMU on its own port
    instead of the OpenCR's; `camera`, `lidar`: their drivers (None: not fitted); `start_yaw`: the robot's heading
    at start (the IMU's yaw counts from there)."""

    def __init__(
        self,
        boards: BusSensors | None,
        imu: ImuDriver | None,
        start_yaw: float,
        clock: Callable[[], float],
        camera: SensorDriver | None = None,
        lidar: SensorDriver | None = None,
    ) -> None:
        self.boards = boards if boards is not None and not boards.empty else None
        self.imu_driver = imu
        self.camera = camera
        self.lidar = lidar
        self.clock = clock
        self.start_yaw = start_yaw
        bus_imu = self.boards is not None and any(b.name == "OpenCR IMU" for b in self.boards.boards)
        bus_feet = self.boards is not None and any("FSR" in b.name for b in self.boards.boards)
        self.imu_name = imu.name if imu is not None else "OpenCR IMU" if bus_imu else ""
        self.senses = Senses(imu=bool(self.imu_name), foot_sensors=bus_feet)
        self._board: BoardReading | None = None
        self._imu: ImuSample | None = None
        self._yaw0: float | None = None
        self._said: set[str] = set()

    def start(self) -> list[str]:
        """Find the boards and start the IMU's thread; what is missing, by name."""
        missing = self.boards.probe() if self.boards is not None else []
        for driver in self._threads():
            driver.start()
        return missing

    def stop(self) -> None:
        for driver in self._threads():
            driver.stop()

    def _threads(self) -> list[ImuDriver | SensorDriver]:
        return [d for d in (self.imu_driver, self.camera, self.lidar) if d is not None]

    def bus_load(self) -> tuple[int, int]:
        """What the boards add to each tick on the servo bus: bytes on the wire, and reads (one bulk read)."""
        if self.boards is None:
            return 0, 0
        return self.boards.wire_bytes(), 1

    def lacks(self, walking_enabled: bool) -> str:
        """Why walking and plans are refused ("" when the robot can do them)."""
        missing = [
            what for what, have in (("an IMU", self.senses.imu), ("foot sensors", self.senses.foot_sensors)) if not have
        ]
        if missing:
            return f"needs {' and '.join(missing)}, which this robot was not given (see docs/real-robot-sensors.md)"
        if not walking_enabled:
            return "needs the legs' controller, which this real robot was not started with"
        return ""

    # the control thread ------------------------------------------------------------------------------------

    def read(self) -> list[str]:
        """This tick's boards and IMU sample; the names of senses lost since the last tick."""
        if self.boards is not None:
            self._board = self.boards.read()
        if self.imu_driver is not None:
            self._imu = self.imu_driver.latest()
        elif self._board is not None:
            self._imu = self._board.imu
        lost = [name for name in self.faults() if name not in self._said]
        self._said = set(self.faults())
        return lost

    def faults(self) -> list[str]:
        """Senses the robot was given that give nothing now."""
        out = []
        if self.senses.imu and self._imu_age() > IMU_STALE_S:
            out.append(self.imu_name)
        if self._board is not None:
            out += [name for name in self._board.lost + self._board.missing if "FSR" in name]
        return out

    def _imu_age(self) -> float:
        return math.inf if self._imu is None else max(0.0, self.clock() - self._imu.stamp_s)

    def fields(self) -> dict[str, np.ndarray | float | None]:
        """The IMU's and feet's part of the tick's `Measurements` (NaN for what is not sensed)."""
        imu = self._imu if self.senses.imu and self._imu_age() <= IMU_STALE_S else None
        feet = self._board.feet if self._board is not None else np.full((2, 4), np.nan)
        out: dict[str, np.ndarray | float | None] = {"foot_forces": feet}
        if imu is None:
            yaw = self.start_yaw
            out |= {
                "imu_quat": np.full(4, np.nan),
                "imu_gyro": np.full(3, np.nan),
                "imu_accel": np.full(3, np.nan),
                "base_quat": np.array([math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]),
            }
            return out
        roll, pitch, yaw = rpy_from_quat(imu.quat)
        if self._yaw0 is None:
            self._yaw0 = yaw
        heading = self.start_yaw + yaw - self._yaw0
        return out | {
            "imu_quat": imu.quat,
            "imu_gyro": imu.gyro,
            "imu_accel": imu.accel,
            "base_quat": quat_from_rpy(roll, pitch, heading),
            "imu_stamp_s": imu.stamp_s,
        }

    # diagnostics ---------------------------------------------------------------------------------------------

    def statuses(self) -> list[DiagnosticStatus]:
        """One status per sense the robot was given: said when it stops, with how old its last reading is."""
        out = []
        if self.senses.imu:
            age = self._imu_age()
            problem = self.imu_driver.problem() if self.imu_driver is not None else ""
            if age > IMU_STALE_S:
                why = problem or ("not answering on the servo bus" if self.imu_driver is None else "no sample")
                message = f"{self.imu_name} lost: {why}" + (f" ({age:.2f} s)" if math.isfinite(age) else "")
                out.append(DiagnosticStatus("sensors/imu", Level.ERROR, message, self.imu_name))
            else:
                out.append(
                    DiagnosticStatus(
                        "sensors/imu",
                        Level.OK,
                        f"{self.imu_name}: sampling",
                        self.imu_name,
                        (("age_s", round(age, 3)),),
                    )
                )
        if self.senses.foot_sensors and self.boards is not None:
            for board in self.boards.boards:
                if "FSR" not in board.name:
                    continue
                health = self.boards.health[board.device_id]
                side = board.name.split()[0]
                values: tuple[tuple[str, float | str], ...] = (
                    ("failed_reads", health.failed_reads),
                    ("crc_errors", health.crc_errors),
                )
                if health.lost or health.missing:
                    why = "stopped answering" if health.lost else "not found on the bus at start"
                    level, message = Level.ERROR, f"{board.name} (id {board.device_id}) {why}"
                else:
                    level, message = Level.OK, f"{board.name}: reading every tick"
                out.append(
                    DiagnosticStatus(f"sensors/{side}_foot", level, message, f"FSR id {board.device_id}", values)
                )
        for kind, driver in (("camera", self.camera), ("lidar", self.lidar)):
            if driver is not None:
                out.append(driver_status(kind, driver))
        return out


def driver_status(kind: str, driver: SensorDriver) -> DiagnosticStatus:
    """A camera's or lidar's health: ERROR with the driver's reason when its frames stop; the counts of what it
    took and dropped."""
    problem = driver.problem()
    values: tuple[tuple[str, float | str], ...] = tuple(
        (key, getattr(driver, key)) for key in ("frames", "scans", "crc_errors") if hasattr(driver, key)
    )
    if problem:
        return DiagnosticStatus(f"sensors/{kind}_driver", Level.ERROR, f"{driver.name}: {problem}", driver.name, values)
    return DiagnosticStatus(f"sensors/{kind}_driver", Level.OK, f"{driver.name}: streaming", driver.name, values)
