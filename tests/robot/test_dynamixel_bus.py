"""The servo bus's one-off reads (what `humanoid hardware check` and start-up ask each servo) on the emulated bus,
when a reply is lost or comes late, as it does from a slow USB adapter or a loaded computer."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Iterator

import pytest

from robot.hardware import control_table as ct
from robot.hardware.bus import FAST, SLOW_ERRORS, SLOW_EVERY, SLOW_POWER, DynamixelBus
from robot.hardware.bus_emulator import BusEmulator
from robot.hardware.config import default_config
from robot.hardware.xm430 import HardwareError


@pytest.fixture
def rig() -> Iterator[tuple[BusEmulator, DynamixelBus]]:
    config = default_config()
    with BusEmulator([j.servo_id for j in config.joints]) as emulator:
        bus = DynamixelBus(dataclasses.replace(config, port=emulator.port_name))
        bus.open()
        try:
            yield emulator, bus
        finally:
            bus.close()


def by_id(bus: DynamixelBus) -> dict:
    return {s.servo_id: s for s in bus.ping_all()}


def test_a_late_reply_is_not_taken_for_the_next_question(rig) -> None:
    """A firmware version that came late once was read as the servo's hardware error (48: "electrical shock,
    overload"), and the check failed a healthy servo."""
    emulator, bus = rig
    sid = bus.joints[3].servo_id
    emulator.set_fault(sid, late_replies=2)  # the ping's reply and the next one come late
    servo = by_id(bus)[sid]
    assert servo.model is not None and servo.firmware == 48
    assert HardwareError(servo.hardware_error) == HardwareError(0)
    assert all(s.hardware_error == 0 and s.firmware == 48 for s in by_id(bus).values())


def test_a_lost_reply_is_asked_again_and_a_real_error_still_shows(rig) -> None:
    emulator, bus = rig
    first, second = bus.joints[0].servo_id, bus.joints[1].servo_id
    emulator.set_fault(first, drop_replies=2)  # its ping, then its firmware read
    emulator.set_temperature(second, 90.0)
    servos = by_id(bus)
    assert servos[first].firmware == 48 and servos[first].hardware_error == 0
    assert HardwareError(servos[second].hardware_error) & HardwareError.OVERHEATING


def test_prepare_survives_a_late_reply(rig) -> None:
    emulator, bus = rig
    emulator.set_fault(bus.joints[5].servo_id, late_replies=1)
    bus.prepare()
    assert all(s.hardware_error == 0 for s in by_id(bus).values())


def test_prepare_survives_a_write_whose_status_was_lost(rig) -> None:
    """A rig on a busy machine lost one write's status and the server would not start ("cannot set address 9")."""
    emulator, bus = rig
    sid = bus.joints[5].servo_id
    emulator.set_fault(sid, drop_write_replies=1)  # the return delay's write lands, its status is lost
    bus.prepare()
    assert emulator.read(sid, ct.RETURN_DELAY_TIME) == 0


def test_a_servo_that_answered_is_read_though_four_replies_in_a_row_are_lost(rig) -> None:
    """A loaded computer missed three replies in a row once (the suite beside two simulations): a servo that is
    there is asked again, waiting longer each time, rather than failing the start."""
    emulator, bus = rig
    emulator.set_fault(bus.joints[2].servo_id, drop_replies=4)
    bus.prepare()
    assert all(s.hardware_error == 0 and s.firmware == 48 for s in by_id(bus).values())


def read_slow_until_answered(bus: DynamixelBus) -> None:
    """The next slow block, asked again if every reply did not come: the emulator is a process of its own, and a
    loaded machine can hold its reply past the packet's few-ms timeout (the robot reads it again at its next turn)."""
    for _ in range(10):
        if bus.read_slow() == 0:
            return
        bus.read_slow()  # the other block, so that this one is next again
    raise AssertionError("the slow block was never answered")


def test_a_tick_reads_what_control_needs_and_the_monitoring_comes_apart(rig) -> None:
    """A tick's read asks current, velocity and position only (one Fast Sync Read); the hardware errors, voltages
    and temperatures come from `read_slow`, one block in turn when due, and show in the next reading. Read inside
    the tick, those blocks made about one tick in 70 late on the rig at 2 Mbps."""
    emulator, bus = rig
    hot = bus.joints[2].servo_id
    index = [j.servo_id for j in bus.joints].index(hot)
    emulator.set_temperature(hot, 85.0)  # past its 80 °C limit: an overheating error too
    asked = emulator.stats().reads_at
    for _ in range(SLOW_EVERY):
        reading = bus.read()
    now = emulator.stats().reads_at
    assert set(now) == set(asked) | {FAST[0]}  # no monitoring read went with the ticks
    assert all(now.get(a, 0) == asked.get(a, 0) for a in (SLOW_ERRORS[0], SLOW_POWER[0]))
    assert now[FAST[0]] - asked.get(FAST[0], 0) >= SLOW_EVERY
    assert not reading.temperatures_c[index] >= 85.0  # not read yet
    assert bus.slow_due
    read_slow_until_answered(bus)  # the hardware errors
    assert not bus.slow_due
    assert HardwareError(int(bus.read().hardware_errors[index])) & HardwareError.OVERHEATING
    while not bus.slow_due:
        bus.read()
    read_slow_until_answered(bus)  # then voltage and temperature
    reading = bus.read()
    assert reading.temperatures_c[index] == pytest.approx(85.0, abs=1.0)
    assert 10.0 < reading.voltages_v[index] < 14.0


def test_monitoring_put_off_by_busy_ticks_is_read_anyway_in_the_end(rig) -> None:
    """After a tick with no room left in its period the slow block waits; after SLOW_MAX_DEFER_TICKS ticks it is
    overdue and read whatever the room, so an overheating servo is still said; with room it is read when due."""
    _, bus = rig
    assert not bus.read_slow_if_room(1.0)  # not due yet
    for _ in range(SLOW_EVERY):
        bus.read()
    assert bus.slow_due and not bus.read_slow_if_room(0.0)  # due, but no room: put off
    bus.read()
    while not bus.slow_overdue:
        assert not bus.read_slow_if_room(0.001)
        bus.read()
    assert bus.read_slow_if_room(0.0)  # overdue: read anyway
    assert not bus.slow_due and not bus.slow_overdue
    while not bus.slow_due:
        bus.read()
    assert bus.read_slow_if_room(bus.slow_read_s() + 0.005)  # room for it: read


def test_the_longest_silence_the_servos_heard_is_told_once(rig) -> None:
    """The robot asks how long the servos went without a packet (past their bus watchdog they take no goals); a
    silence split across two ticks counts whole, and the answer starts again from zero once told."""
    _, bus = rig
    bus.read()
    bus.take_longest_silence_s()
    time.sleep(0.15)  # the host paused: the servos heard nothing
    bus.read()
    assert bus.take_longest_silence_s() >= 0.15
    assert bus.take_longest_silence_s() == 0.0  # told once
