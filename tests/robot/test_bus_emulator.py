"""The Protocol 2.0 bus emulator, driven by the real dynamixel-sdk through its pseudo-terminal, as a U2D2 would be."""

from __future__ import annotations

import time
from collections.abc import Iterator

import dynamixel_sdk.port_handler
import pytest
from dynamixel_sdk import (
    COMM_RX_CORRUPT,
    COMM_RX_TIMEOUT,
    COMM_SUCCESS,
    GroupSyncRead,
    GroupSyncWrite,
    PacketHandler,
    PortHandler,
)

from robot.hardware import control_table as ct
from robot.hardware.bus_emulator import BusEmulator
from robot.hardware.protocol2 import ALERT_BIT, PacketParser, crc16, encode, stuff, unstuff
from robot.hardware.xm430 import HardwareError

IDS = list(range(1, 25))


def test_crc_and_stuffing_follow_the_specification() -> None:
    # the specification's example: read 4 bytes at 132 from ID 1 ends with CRC 1D 15
    assert crc16(bytes.fromhex("fffffd0001070002840004 00".replace(" ", ""))) == 0x151D
    assert stuff(b"\x03\xff\xff\xfd\x10") == b"\x03\xff\xff\xfd\xfd\x10"
    assert unstuff(stuff(b"\x03\xff\xff\xfd\x10")) == b"\x03\xff\xff\xfd\x10"
    packet = encode(1, 0x03, b"\xff\xff\xfd\x10")
    (parsed,) = PacketParser().feed(b"\x00junk" + packet)
    assert parsed.params == b"\xff\xff\xfd\x10" and parsed.crc_ok
    (broken,) = PacketParser().feed(packet[:-1] + b"\x00")
    assert not broken.crc_ok


@pytest.fixture
def bus(monkeypatch) -> Iterator[tuple[BusEmulator, PortHandler, PacketHandler]]:
    # The SDK's own port waits 34 ms for a reply (twice its 16 ms USB latency timer, plus 2 ms). With one core kept
    # busy the emulator's process was once later than that, and a ping timed out: these tests check the protocol, so
    # the port waits ~0.5 s instead (a missing servo's timeouts take that long).
    monkeypatch.setattr(dynamixel_sdk.port_handler, "LATENCY_TIMER", 250)
    with BusEmulator(IDS) as emulator:
        port = PortHandler(emulator.port_name)  # the SDK's own port
        assert port.openPort() and port.setBaudRate(1_000_000)
        yield emulator, port, PacketHandler(2.0)
        port.closePort()


def test_every_servo_answers_a_ping_with_its_model(bus) -> None:
    _emulator, port, packets = bus
    for servo_id in IDS:
        model, result, error = packets.ping(port, servo_id)
        assert (model, result, error) == (ct.XM430_W350_MODEL, COMM_SUCCESS, 0)
    found, result = packets.broadcastPing(port)
    assert result == COMM_SUCCESS and sorted(found) == IDS and found[5] == [ct.XM430_W350_MODEL, 48]
    _, result, _ = packets.ping(port, 99)
    assert result == COMM_RX_TIMEOUT  # nobody there


def test_sync_write_moves_every_servo_and_sync_read_reads_them_all(bus) -> None:
    _emulator, port, packets = bus
    torque = GroupSyncWrite(port, packets, ct.TORQUE_ENABLE.address, 1)
    goal = GroupSyncWrite(port, packets, ct.GOAL_POSITION.address, 4)
    for servo_id in IDS:
        torque.addParam(servo_id, [1])
        goal.addParam(servo_id, list(ct.GOAL_POSITION.encode(2048 + 10 * servo_id)))
    assert torque.txPacket() == COMM_SUCCESS and goal.txPacket() == COMM_SUCCESS
    reader = GroupSyncRead(port, packets, ct.PRESENT_POSITION.address, 4)
    for servo_id in IDS:
        reader.addParam(servo_id)
    deadline = time.monotonic() + 3
    while True:
        assert reader.txRxPacket() == COMM_SUCCESS
        positions = {i: reader.getData(i, ct.PRESENT_POSITION.address, 4) for i in IDS}
        if all(abs(positions[i] - (2048 + 10 * i)) <= 1 for i in IDS) or time.monotonic() > deadline:
            break
    assert all(abs(positions[i] - (2048 + 10 * i)) <= 1 for i in IDS)
    temperature, result, _ = packets.read1ByteTxRx(port, 3, ct.PRESENT_TEMPERATURE.address)
    assert result == COMM_SUCCESS and 20 <= temperature <= 40


def test_eeprom_is_locked_while_torque_is_on_and_limits_are_enforced(bus) -> None:
    _emulator, port, packets = bus
    result, error = packets.write1ByteTxRx(port, 1, ct.TORQUE_ENABLE.address, 1)
    assert (result, error) == (COMM_SUCCESS, 0)
    result, error = packets.write1ByteTxRx(port, 1, ct.OPERATING_MODE.address, 1)
    assert result == COMM_SUCCESS and error == 7  # access error
    result, error = packets.write4ByteTxRx(port, 1, ct.GOAL_POSITION.address, 5000)
    assert error == 6  # beyond the position limit


def test_faults_a_dead_servo_timeouts_crc_errors_and_overheating(bus) -> None:
    emulator, port, packets = bus
    emulator.set_fault(4, dead=True)
    emulator.set_fault(5, drop_replies=1)
    emulator.set_fault(6, corrupt_replies=1)
    assert packets.ping(port, 4)[1] == COMM_RX_TIMEOUT
    assert packets.read4ByteTxRx(port, 5, ct.PRESENT_POSITION.address)[1] == COMM_RX_TIMEOUT
    assert packets.read4ByteTxRx(port, 5, ct.PRESENT_POSITION.address)[1] == COMM_SUCCESS  # only the one dropped
    assert packets.read4ByteTxRx(port, 6, ct.PRESENT_POSITION.address)[1] == COMM_RX_CORRUPT
    reader = GroupSyncRead(port, packets, ct.PRESENT_POSITION.address, 4)
    for servo_id in (3, 4):
        reader.addParam(servo_id)
    # the SDK fails the whole sync read on the first servo that does not answer, having read the ones before it
    assert reader.txRxPacket() == COMM_RX_TIMEOUT
    assert len(reader.data_dict[3]) == 4 and not reader.data_dict[4]

    packets.write1ByteTxRx(port, 7, ct.TORQUE_ENABLE.address, 1)
    emulator.set_temperature(7, 85.0)
    value, result, error = packets.read1ByteTxRx(port, 7, ct.HARDWARE_ERROR_STATUS.address)
    assert result == COMM_SUCCESS and error & ALERT_BIT and HardwareError(value) == HardwareError.OVERHEATING
    assert packets.read1ByteTxRx(port, 7, ct.TORQUE_ENABLE.address)[0] == 0  # it cut its own torque
    assert packets.write1ByteTxRx(port, 7, ct.TORQUE_ENABLE.address, 1)[1] == ALERT_BIT | 1  # refused: latched
    emulator.set_temperature(7, 40.0)
    assert packets.reboot(port, 7)[0] == COMM_SUCCESS
    assert packets.read1ByteTxRx(port, 7, ct.HARDWARE_ERROR_STATUS.address)[:2] == (0, COMM_SUCCESS)


def test_fast_sync_read_answers_every_servo_in_one_packet(bus) -> None:
    emulator, port, packets = bus
    goal = GroupSyncWrite(port, packets, ct.GOAL_POSITION.address, 4)
    torque = GroupSyncWrite(port, packets, ct.TORQUE_ENABLE.address, 1)
    for servo_id in IDS:
        torque.addParam(servo_id, [1])
        goal.addParam(servo_id, list(ct.GOAL_POSITION.encode(2048 - 7 * servo_id)))
    assert torque.txPacket() == COMM_SUCCESS and goal.txPacket() == COMM_SUCCESS
    reader = GroupSyncRead(port, packets, ct.PRESENT_POSITION.address, 4)
    for servo_id in IDS:
        reader.addParam(servo_id)
    deadline = time.monotonic() + 3
    while True:
        assert reader.fastSyncRead() == COMM_SUCCESS
        positions = {i: reader.getData(i, ct.PRESENT_POSITION.address, 4) for i in IDS}
        if all(abs(positions[i] - (2048 - 7 * i)) <= 1 for i in IDS) or time.monotonic() > deadline:
            break
    assert all(abs(positions[i] - (2048 - 7 * i)) <= 1 for i in IDS)
    before = emulator.stats().replies
    reads = 0
    for _ in range(5):
        assert reader.fastSyncRead() == COMM_SUCCESS
        reads += 1
    assert emulator.stats().replies - before == reads  # one reply packet per read, not one per servo

    # a servo that does not answer breaks the chain: the read fails, and no stale data is passed off as read
    emulator.set_fault(9, dead=True)
    assert reader.fastSyncRead() in (COMM_RX_TIMEOUT, COMM_RX_CORRUPT)
    emulator.set_fault(9, dead=False)
    emulator.set_fault(12, corrupt_replies=1)
    assert reader.fastSyncRead() == COMM_RX_CORRUPT
    assert reader.fastSyncRead() == COMM_SUCCESS


def test_the_bus_watchdog_stops_a_servo_that_hears_nothing(bus) -> None:
    emulator, port, packets = bus
    assert packets.write1ByteTxRx(port, 2, ct.TORQUE_ENABLE.address, 1)[:2] == (COMM_SUCCESS, 0)
    # a watchdog of 1 s (a test process may be paused for 100 ms on a loaded machine, a robot's is not)
    assert packets.write1ByteTxRx(port, 2, ct.BUS_WATCHDOG.address, 50)[:2] == (COMM_SUCCESS, 0)
    for _ in range(10):  # heard every 20 ms: nothing trips
        packets.write4ByteTxRx(port, 2, ct.GOAL_POSITION.address, 2048)
        time.sleep(0.02)
    assert emulator.read(2, ct.BUS_WATCHDOG) == 50
    for _ in range(5):  # 100 ms, then a far goal; set again if this process was paused between the two
        packets.write1ByteTxRx(port, 2, ct.BUS_WATCHDOG.address, 0)
        packets.write1ByteTxRx(port, 2, ct.BUS_WATCHDOG.address, 5)
        if packets.write4ByteTxRx(port, 2, ct.GOAL_POSITION.address, 3000)[:2] == (COMM_SUCCESS, 0):
            break
    else:
        pytest.fail("the watchdog tripped before every goal")
    deadline = time.monotonic() + 5.0  # the host goes quiet mid-move
    while emulator.read(2, ct.BUS_WATCHDOG) != -1 and time.monotonic() < deadline:
        time.sleep(0.01)
    assert emulator.read(2, ct.BUS_WATCHDOG) == -1
    stopped_at = emulator.position_rad(2)
    time.sleep(0.1)
    assert emulator.position_rad(2) == pytest.approx(stopped_at, abs=1e-3)  # it stopped short of its goal
    assert abs(stopped_at - (3000 - 2048) / ct.POSITION_PER_RAD) > 0.1
    assert emulator.read(2, ct.TORQUE_ENABLE) == 1  # holding, torque on
    # no new goal, nor a new watchdog value, until the host clears it with 0
    assert packets.write4ByteTxRx(port, 2, ct.GOAL_POSITION.address, 3000)[1] == 4  # data range error
    assert packets.write1ByteTxRx(port, 2, ct.BUS_WATCHDOG.address, 5)[1] == 4
    assert packets.write1ByteTxRx(port, 2, ct.BUS_WATCHDOG.address, 0)[:2] == (COMM_SUCCESS, 0)
    assert packets.write4ByteTxRx(port, 2, ct.GOAL_POSITION.address, 3000)[:2] == (COMM_SUCCESS, 0)


def _start_slowly(conn, seconds: float) -> None:
    time.sleep(seconds)  # as the rig's process building its world on a machine whose caches are cold
    conn.send("/dev/pts/fake")
    conn.recv()


def _fail_at_once(conn) -> None:
    raise SystemExit(3)


class _SlowEmulator(BusEmulator):
    start_timeout_s = 60.0

    def __init__(self, target, *args) -> None:
        super().__init__([])
        self._target, self._args = target, args

    def _child(self):
        return self._target, self._args

    def stop(self) -> None:
        if self._process is not None:
            self._process.kill()
            self._process.join()


def test_an_emulator_slower_to_start_than_a_reply_is_waited_for_and_one_that_dies_says_so_at_once() -> None:
    slow = _SlowEmulator(_start_slowly, 2.0)
    slow.start_timeout_s = 1.0
    with pytest.raises(RuntimeError, match="did not start within 1 s"):
        slow.start()
    slow.stop()
    patient = _SlowEmulator(_start_slowly, 2.0)
    patient.start_timeout_s = 120.0
    patient.start()
    assert patient.port_name == "/dev/pts/fake"
    patient.stop()
    dying = _SlowEmulator(_fail_at_once)
    with pytest.raises(RuntimeError, match="exited while starting"):
        dying.start()
