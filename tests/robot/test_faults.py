"""Faults inside the robot worker: physics that diverges and a control tick that raises. Each is said, stops the
robot (e-stop latched with the cause) and leaves the loop running, so the operator can release and go on."""

from __future__ import annotations

import math

from robot.interface import Fault, InjectFault, Level, Mode, ReleaseEStop


def events_of(worker, kind: str) -> list:
    return [e for e in worker.recent_events() if e.kind == kind]


def test_a_diverging_simulation_is_stopped_and_the_robot_stood_up_again(make_worker) -> None:
    worker = make_worker(realtime=False)
    assert worker.wait_for(lambda s: s.sim_time_s > 0.5, 60)
    start = worker.state().base_position
    assert worker.submit(InjectFault(Fault.SIM_DIVERGE)).accepted
    assert worker.wait_for(lambda s: s.estop_latched, 30)
    diverged = events_of(worker, "sim/diverged")
    assert len(diverged) == 1 and diverged[0].level == Level.ERROR and "bad velocity" in diverged[0].message
    latched = events_of(worker, "estop/latched")[-1]
    assert latched.data["source"] == "sim-diverged"
    assert worker.wait_for(lambda s: any(e.kind == "robot/reset" for e in worker.recent_events()), 30)
    at_reset = worker.state().sim_time_s
    assert worker.wait_for(lambda s: s.sim_time_s > at_reset + 1.0, 60)  # the physics goes on
    state = worker.state()
    assert not state.fallen and all(math.isfinite(v) for v in state.qpos)
    assert math.dist(state.base_position[:2], start[:2]) < 0.05  # standing at its start pose again
    assert worker.submit(ReleaseEStop()).accepted
    assert worker.wait_for(lambda s: s.mode != Mode.ESTOP, 30)


def test_a_control_tick_that_raises_stops_the_robot_says_so_once_a_second_and_the_loop_goes_on(make_worker) -> None:
    worker = make_worker(realtime=True)
    assert worker.wait_for(lambda s: s.sim_time_s > 0.3, 30)
    assert worker.submit(InjectFault(Fault.CONTROL_ERROR, value=150)).accepted  # 1.5 s of failing ticks
    assert worker.wait_for(lambda s: s.estop_latched, 10)
    stopped_at = worker.state().sim_time_s
    assert worker.wait_for(lambda s: s.sim_time_s > stopped_at + 1.0, 30)  # ticking (and stepping) again
    errors = events_of(worker, "control/error")
    assert 1 <= len(errors) <= 3 and "injected controller fault" in errors[0].message  # not 150 of them
    latches = events_of(worker, "estop/latched")
    assert len(latches) == 1 and latches[0].data["source"] == "control-error"
    assert worker.submit(ReleaseEStop()).accepted


def test_a_controller_fault_must_last_a_sensible_number_of_ticks(make_worker) -> None:
    worker = make_worker(realtime=False)
    for ticks in (0, 5000, float("nan")):
        assert not worker.submit(InjectFault(Fault.CONTROL_ERROR, value=ticks)).accepted
    assert not worker.state().estop_latched
