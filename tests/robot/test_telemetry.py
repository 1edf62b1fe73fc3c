"""Telemetry (what sessions record and replay) and the battery model it carries."""

from __future__ import annotations

import numpy as np
import pytest

from robot.power.battery import Battery, PackSpec, ServoElectrical
from robot.telemetry import TelemetryBatch, TelemetryLayout, TelemetryRing, TelemetrySampler


def test_a_full_pack_at_rest_reads_its_open_circuit_voltage_and_sags_under_load() -> None:
    battery = Battery()
    assert battery.reading.voltage_v == pytest.approx(25.2, abs=0.01)
    loaded = battery.step(servo_power_w=200.0, dt_s=0.01)
    assert loaded.voltage_v < 25.2 - 0.5  # ~0.06 ohm at ~10 A
    assert loaded.current_a * loaded.voltage_v == pytest.approx(loaded.power_w, rel=1e-6)
    assert loaded.power_w == pytest.approx(200.0 / 0.9 + PackSpec().base_load_w)


def test_charge_drains_with_the_current_drawn() -> None:
    battery = Battery(PackSpec(base_load_w=0.0, converter_efficiency=1.0))
    for _ in range(360):  # ten seconds per step: an hour at ~2.2 A empties most of a 2.2 Ah pack
        reading = battery.step(servo_power_w=2.2 * battery.reading.voltage_v, dt_s=10.0)
    assert reading.soc < 0.1
    assert reading.voltage_v < 6 * 3.7  # a flat 6S pack under load


def test_servos_draw_for_torque_held_and_work_done_but_not_for_braking() -> None:
    servo = ServoElectrical()
    idle = servo.power_w(np.zeros(24), np.zeros(24))
    stall = servo.power_w(np.full(1, 4.1), np.zeros(1))
    assert idle == pytest.approx(24 * 0.04 * 12.0)
    assert stall == pytest.approx(12.0 * 2.3 + 0.04 * 12.0, rel=1e-6)  # stall current at 12 V
    motoring = servo.power_w(np.array([1.0]), np.array([2.0]))
    braking = servo.power_w(np.array([1.0]), np.array([-2.0]))
    assert motoring == pytest.approx(braking + 2.0)


def test_the_ring_hands_out_rows_by_number_and_says_when_old_ones_are_gone() -> None:
    ring = TelemetryRing(capacity=5)
    for i in range(8):
        ring.append(np.array([float(i)]))
    batch = ring.since(0)
    assert batch is not None and batch.first_seq == 3 and batch.rows[:, 0].tolist() == [3, 4, 5, 6, 7]
    assert ring.since(6).rows[:, 0].tolist() == [6, 7]
    assert ring.since(8) is None
    copy = TelemetryRing()
    copy.extend(ring.since(3))
    copy.extend(TelemetryBatch(10, np.array([[10.0]])))  # rows 8 and 9 lost on the way
    assert copy.since(0).first_seq == 10 and copy.next_seq == 11


def test_the_sampler_takes_every_nth_tick_at_least_at_the_rate_asked() -> None:
    layout = TelemetryLayout.for_robot(("a", "b"), nq=9, n_mocap=1)
    sampler = TelemetrySampler(layout, control_hz=100.0, rate_hz=30.0)
    assert sampler.every == 3 and sampler.rate_hz == pytest.approx(33.33, abs=0.01)
    for tick in range(9):
        if sampler.due():
            sampler.record({"sim_time_s": tick * 0.01, "joint_target": np.array([1.0, 2.0])})
    batch = sampler.ring.since(0)
    cols = layout.slices()
    assert batch.rows[:, cols["sim_time_s"]].ravel().tolist() == pytest.approx([0.02, 0.05, 0.08])
    assert batch.rows[0, cols["joint_target"]].tolist() == [1.0, 2.0]
    assert np.isnan(batch.rows[0, cols["battery_v"]]).all()  # not given: not measured
    assert TelemetryLayout.from_json(layout.to_json()) == layout


def test_the_worker_samples_its_motion_and_signals_in_simulated_time(make_worker) -> None:
    worker = make_worker(realtime=False)
    assert worker.wait_for(lambda s: s.sim_time_s >= 2.0, 30.0)
    description = worker.describe()
    layout = TelemetryLayout.from_json(description.telemetry_layout)
    assert description.telemetry_hz >= 30.0
    batch = worker.telemetry_since(0)
    cols = layout.slices()
    sim = batch.rows[:, cols["sim_time_s"]].ravel()
    assert np.allclose(np.diff(sim), 0.03, atol=1e-6) and sim[-1] >= 1.9
    last = batch.rows[-1]
    qpos = last[cols["qpos"]]
    assert qpos.size == len(worker.state().qpos) and 0.2 < qpos[2] < 0.35  # the trunk, standing
    com = last[cols["com"]]
    assert np.linalg.norm(com[:2] - qpos[:2]) < 0.05 and 0.1 < com[2] < qpos[2]
    torque = last[cols["joint_torque"]]
    knees = [layout.joint_names.index(n) for n in layout.joint_names if "knee" in n]
    assert np.all(np.abs(torque[knees]) > 0.05)  # standing, the knees hold the body up
    assert 0.0 < last[cols["tick_ms"]][0] < 1000.0
    soc = batch.rows[:, cols["battery_soc"]].ravel()
    assert soc[-1] < soc[0] <= 1.0  # a standing robot still drains its pack
    power = worker.state().power
    assert power is not None and 20.0 < power.voltage_v < 25.3 and power.current_a > 0.5
