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
