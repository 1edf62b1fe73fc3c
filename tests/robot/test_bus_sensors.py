"""The OpenCR's IMU and the FSR foot modules on the emulated servo bus, read by the real dynamixel-sdk's bulk read
as the robot reads them each tick."""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np
import pytest
from dynamixel_sdk import PacketHandler

from robot.hardware import fsr, opencr
from robot.hardware.bus import LowLatencyPortHandler
from robot.hardware.bus_emulator import BusEmulator
from robot.hardware.bus_sensors import BusSensors
from robot.sensors.imu import quat_from_rpy, rpy_from_quat

# how long past a reply's wire time the port waits: a loaded machine delays the emulator's process; these tests
# check what the boards say, not how fast (a missing board's reads take that long)
REPLY_MARGIN_MS = 250.0


@pytest.fixture
def rig() -> Iterator[tuple[BusEmulator, BusSensors]]:
    with BusEmulator([1, 2], sensors=True) as emulator:
        port = LowLatencyPortHandler(emulator.port_name, reply_margin_ms=REPLY_MARGIN_MS)
        assert port.openPort() and port.setBaudRate(1_000_000)
        yield emulator, BusSensors(port, PacketHandler(2.0))
        port.closePort()


def test_imu_registers_round_trip_in_the_trunk_frame() -> None:
    quat = quat_from_rpy(0.2, -0.1, 1.0)
    registers = opencr.encode_registers(quat, np.array([0.5, -0.3, 0.1]), np.array([1.0, -2.0, 9.5]))
    table = bytearray(opencr.TABLE_SIZE)
    for f, value in registers.items():
        table[f.address : f.address + f.size] = f.encode(value)
    sample = opencr.decode_block(bytes(table[opencr.TICK_BLOCK[0] :]), 1.0)
    assert np.allclose(rpy_from_quat(sample.quat), (0.2, -0.1, 1.0), atol=2e-3)  # 0.1 deg resolution
    assert np.allclose(sample.gyro, [0.5, -0.3, 0.1], atol=2e-3)
    assert np.allclose(sample.accel, [1.0, -2.0, 9.5], atol=2e-3)


def test_board_registers_use_the_documented_addresses() -> None:
    assert opencr.OPENCR_ID == 200 and opencr.GYRO[0].address == 32 and opencr.ACCEL[0].address == 38
    assert opencr.RPY[0].address == 44 and opencr.TICK_BLOCK == (31, 19)
    assert (fsr.RIGHT_FSR_ID, fsr.LEFT_FSR_ID) == (111, 112) and fsr.TICK_BLOCK == (26, 10)
    # the board sits half a turn about z: its +x gyro is the trunk's -x
    registers = opencr.encode_registers(np.array([1.0, 0, 0, 0]), np.array([1.0, 0, 0]), np.zeros(3))
    assert registers[opencr.GYRO[0]] < 0


def test_imu_and_feet_are_read_in_one_bulk_read(rig) -> None:
    emulator, sensors = rig
    assert sensors.probe() == []
    tilt = quat_from_rpy(math.radians(10), 0.0, 0.0)
    emulator.sense_imu(tilt, [0.0, 0.4, 0.0], [0.0, 1.7, 9.6])
    emulator.sense_foot(fsr.LEFT_FSR_ID, [10.0, 12.0, 8.0, 9.0])
    emulator.sense_foot(fsr.RIGHT_FSR_ID, [0.0, 0.0, 0.0, 0.0])
    reading = sensors.read()
    assert reading.imu is not None and reading.lost == () and reading.missing == ()
    assert math.degrees(rpy_from_quat(reading.imu.quat)[0]) == pytest.approx(10.0, abs=0.2)
    assert reading.imu.gyro[1] == pytest.approx(0.4, abs=0.01) and reading.imu.voltage_v == pytest.approx(12.0)
    assert np.allclose(reading.feet, [[10, 12, 8, 9], [0, 0, 0, 0]], atol=1e-3)
    stats_before = emulator.stats()
    sensors.read()
    assert emulator.stats().packets_in == stats_before.packets_in + 1  # one instruction for all three boards


def test_a_board_that_stops_answering_is_lost_and_the_others_keep_coming(rig) -> None:
    emulator, sensors = rig
    sensors.probe()
    emulator.set_fault(opencr.OPENCR_ID, dead=True)
    emulator.sense_foot(fsr.RIGHT_FSR_ID, [5.0, 5.0, 5.0, 5.0])
    for _ in range(3):
        reading = sensors.read()
    assert reading.lost == ("OpenCR IMU",) and reading.imu is None
    emulator.sense_foot(fsr.RIGHT_FSR_ID, [7.0, 7.0, 7.0, 7.0])
    assert np.allclose(sensors.read().feet[1], 7.0)


def test_a_corrupt_reply_is_counted_and_the_last_values_stand(rig) -> None:
    emulator, sensors = rig
    sensors.probe()
    emulator.sense_foot(fsr.LEFT_FSR_ID, [3.0, 3.0, 3.0, 3.0])
    sensors.read()
    emulator.set_fault(fsr.LEFT_FSR_ID, corrupt_replies=1)
    emulator.sense_foot(fsr.LEFT_FSR_ID, [9.0, 9.0, 9.0, 9.0])
    reading = sensors.read()
    assert np.allclose(reading.feet[0], 3.0) and reading.lost == ()
    assert sensors.health[fsr.LEFT_FSR_ID].crc_errors == 1
    assert np.allclose(sensors.read().feet[0], 9.0)


def test_a_board_not_on_the_bus_is_missing() -> None:
    with BusEmulator([1]) as emulator:  # no sensor boards
        port = LowLatencyPortHandler(emulator.port_name, reply_margin_ms=REPLY_MARGIN_MS)
        assert port.openPort() and port.setBaudRate(1_000_000)
        sensors = BusSensors(port, PacketHandler(2.0))
        assert len(sensors.probe()) == 3
        reading = sensors.read()
        assert reading.imu is None and np.isnan(reading.feet).all() and len(reading.missing) == 3
        port.closePort()


def test_the_boards_read_is_in_the_ticks_bus_budget(rig) -> None:
    from robot.hardware.bus import tick_budget

    _emulator, sensors = rig
    # the bulk read: instruction (10 + 5 a board), the OpenCR's 19 bytes and each foot's 10, with 11 bytes of
    # status each
    assert sensors.wire_bytes() == 10 + 15 + (11 + 19) + 2 * (11 + 10)
    alone = tick_budget(24, 2_000_000, 100, 1.0)
    both = tick_budget(24, 2_000_000, 100, 1.0, extra_bytes=sensors.wire_bytes(), extra_reads=1)
    assert both.bytes_per_tick == alone.bytes_per_tick + 97
    assert both.utilisation == pytest.approx(0.545, abs=0.002) and both.fits  # 24 servos + OpenCR + 2 FSR at 2 Mbps
    assert not tick_budget(24, 1_000_000, 100, 1.0, extra_bytes=97, extra_reads=1).fits  # 87 %: too tight


def test_a_stale_reply_that_trips_the_sdks_fast_read_is_read_again_the_plain_way(monkeypatch) -> None:
    """A board's reply that comes after the bulk read gave up on it can land in the next tick's fast servo read,
    whose SDK parser then indexes an empty reply (IndexError: a valid packet, but not the fast read's). That is
    junk on the line, as a bad CRC is: counted, and the servos read again the plain way, not a failed tick."""
    import dataclasses

    from dynamixel_sdk import GroupSyncRead

    from robot.hardware.bus import DynamixelBus
    from robot.hardware.config import default_config

    config = dataclasses.replace(default_config(), reply_margin_ms=100.0)
    with BusEmulator([j.servo_id for j in config.joints]) as emulator:
        bus = DynamixelBus(dataclasses.replace(config, port=emulator.port_name))
        bus.open()
        try:
            bus.prepare()
            expected = bus.read().positions
            real = GroupSyncRead.fastSyncRead
            tripped = []

            def stale_packet_first(reader: GroupSyncRead) -> int:
                if not tripped:
                    tripped.append(True)
                    raise IndexError("bytearray index out of range")
                return real(reader)

            monkeypatch.setattr(GroupSyncRead, "fastSyncRead", stale_packet_first)
            reading = bus.read()
            assert tripped and reading.lost == () and reading.failed_reads == 0
            assert np.allclose(reading.positions, expected, atol=1e-3) and bus.counters.crc_errors == 1
        finally:
            bus.close()
