"""Diagnostics of a running robot: a sensor that falls silent is STALE, and the robot goes on (it is not unsafe)."""

from __future__ import annotations

from robot.interface import Fault, InjectFault, Level


def test_a_silent_camera_goes_stale_while_the_robot_keeps_working(make_worker) -> None:
    worker = make_worker(realtime=False, perception=True)
    assert worker.wait_for(lambda s: s.perception is not None and s.perception.frame_seq > 3, 120)
    assert worker.sample_diagnostics().find("sensors/camera").level == Level.OK
    assert worker.submit(InjectFault(Fault.CAMERA_STALE)).accepted
    silenced_at = worker.state().sim_time_s
    assert worker.wait_for(lambda s: s.sim_time_s > silenced_at + 1.6, 120)
    sample = worker.sample_diagnostics()
    camera = sample.find("sensors/camera")
    assert camera.level == Level.STALE and "no camera data" in camera.message
    assert sample.find("sensors/lidar").level in (Level.OK, Level.WARN)  # the lidar still scans
    assert not worker.state().estop_latched
    assert worker.submit(InjectFault(Fault.CLEAR)).accepted
    cleared_at = worker.state().sim_time_s
    assert worker.wait_for(lambda s: s.perception.frame_sim_s > cleared_at, 120)
    assert worker.sample_diagnostics().find("sensors/camera").level in (Level.OK, Level.WARN)


def test_a_real_time_robot_says_whether_its_walk_plans_come_on_time(make_worker) -> None:
    """In real time a late walk plan is walked on the last one's steps: diagnostics count them (headless, the
    walk waits for its plans and there is nothing to say)."""
    worker = make_worker(realtime=True)
    assert worker.wait_for(lambda s: s.sim_time_s > 1.5, 60)
    gait = worker.sample_diagnostics().find("control/gait")
    assert gait is not None and gait.level in (Level.OK, Level.WARN)  # WARN: a machine busy enough to make them late
    assert {"late_plans", "late_plans_per_s", "mean_late_ms"} <= dict(gait.values).keys()
    headless = make_worker(realtime=False)
    assert headless.wait_for(lambda s: s.sim_time_s > 0.5, 60)
    assert headless.sample_diagnostics().find("control/gait") is None
