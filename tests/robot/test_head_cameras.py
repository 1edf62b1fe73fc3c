"""The real head cameras: a UVC/network camera through OpenCV (served here as an MJPEG stream over HTTP, opened by
URL) and the RealSense D435i through pyrealsense2 (frames injected through its software device). The RealSense's
colour and depth give the same detections and 3D positions as the simulated camera's own frames; a stalled and a
disconnected camera are said."""

from __future__ import annotations

import math
import time

import mujoco
import numpy as np
import pytest

from robot.model.world import generate_world
from robot.perception.camera import RGBDImage
from robot.perception.suite import SensorSuite
from robot.sensors.camera import UvcCamera, capture_source
from robot.sensors.mjpeg_server import MjpegServer
from robot.sim.backend import MujocoSimBackend


def wait(predicate, timeout: float = 15.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if value := predicate():
            return value
        time.sleep(0.02)
    raise AssertionError("condition not met in time")


@pytest.fixture(scope="module")
def suite() -> SensorSuite:
    s = SensorSuite(generate_world(0))
    yield s
    s.close()


@pytest.fixture(scope="module")
def counter_view(suite: SensorSuite) -> RGBDImage:
    """What the simulated head camera sees 0.9 m from the kitchen counter, looking down at its objects."""
    qpos = MujocoSimBackend(suite.layout, suite.model).qpos()
    qpos[0:2] = (1.55 - 0.9, 0.35)
    qpos[3:7] = (1.0, 0.0, 0.0, 0.0)
    qpos[suite.model.joint("head_tilt").qposadr[0]] = -math.atan2(0.43 - 0.25, 0.9 + 0.08)
    suite.data.qpos[:] = qpos
    mujoco.mj_kinematics(suite.model, suite.data)
    mujoco.mj_camlight(suite.model, suite.data)
    return suite.camera.capture(suite.data)


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    mse = float(np.mean((a.astype(float) - b.astype(float)) ** 2))
    return 10 * math.log10(255.0**2 / max(mse, 1e-9))


def test_a_source_names_a_device_index_or_a_path() -> None:
    assert capture_source("0") == 0 and capture_source("/dev/video2") == "/dev/video2"
    assert capture_source("rtsp://camera.local/stream") == "rtsp://camera.local/stream"


def test_a_network_camera_streams_through_opencv_and_a_stall_and_a_disconnect_are_said(counter_view) -> None:
    with MjpegServer(counter_view.rgb) as server:
        camera = UvcCamera(server.url, stall_after_s=0.5)
        camera.start()
        try:
            image = wait(lambda: camera.frames >= 3 and camera.latest())
            assert image.rgb.shape == counter_view.rgb.shape and image.depth is None
            assert psnr(image.rgb, counter_view.rgb) > 30  # the JPEG's loss only
            assert camera.problem() == ""
            server.stall = True
            assert "stalled" in wait(camera.problem)
            server.stall = False
            wait(lambda: camera.problem() == "")
            server.disconnect()
            assert wait(lambda: (p := camera.problem()) and "stalled" not in p and p)
        finally:
            camera.stop()


def test_an_unopenable_source_is_said() -> None:
    camera = UvcCamera("http://127.0.0.1:9/none.mjpg")
    camera.start()
    try:
        assert "cannot open" in wait(lambda: camera.problem() != "not started" and camera.problem())
    finally:
        camera.stop()


def test_realsense_frames_detect_and_localise_as_the_simulated_ones(suite, counter_view) -> None:
    pytest.importorskip("pyrealsense2", reason="the realsense extra is not installed (or libusb-1.0-0 is missing)")
    from robot.sensors.realsense import RealSenseCamera
    from robot.sensors.realsense_emulator import SoftwareSource

    source = SoftwareSource(counter_view.intrinsics)
    camera = RealSenseCamera(source, stall_after_s=0.5)
    camera.start()
    try:
        image = wait(lambda: source.inject(counter_view.rgb, counter_view.depth) or camera.latest())
        want = counter_view.intrinsics
        assert image.depth is not None and (image.intrinsics.width, image.intrinsics.height) == (
            want.width,
            want.height,
        )
        assert image.intrinsics.fx == pytest.approx(want.fx) and image.intrinsics.cx == pytest.approx(want.cx)
        assert np.array_equal(image.rgb, counter_view.rgb)
        valid = (image.depth > 0) & (counter_view.depth > 0)
        assert np.mean(np.abs(image.depth[valid] - counter_view.depth[valid]) < 0.002) > 0.95
        pose = counter_view.world_from_camera
        simulated = {
            d.label: d
            for d in suite.detector.detect(counter_view.rgb, counter_view.depth, counter_view.intrinsics, pose)
        }
        real = {d.label: d for d in suite.detector.detect(image.rgb, image.depth, image.intrinsics, pose)}
        assert set(real) == set(simulated) == {"red mug", "blue bottle", "green apple"}
        for label, found in real.items():
            assert math.dist(found.position, simulated[label].position) < 0.01
        assert wait(camera.problem) and "stalled" in camera.problem()  # nothing injected since
        source.fail()
        assert wait(lambda: (p := camera.problem()) and "stalled" not in p and p)
    finally:
        camera.stop()


def test_the_rigs_camera_stream_reaches_the_realsense_driver_and_its_end_is_said(counter_view, tmp_path) -> None:
    """The hardware-in-the-loop rig's frames, over its socket, into librealsense's software device and out of the
    RealSense driver as they went in; the rig going away is the camera unplugged."""
    pytest.importorskip("pyrealsense2", reason="the realsense extra is not installed (or libusb-1.0-0 is missing)")
    import socket
    import threading

    from robot.sensors.realsense import RealSenseCamera
    from robot.sensors.realsense_rig import RigFrameSource
    from robot.sensors.rgbd_stream import RgbdFrame, encode_frame

    path = str(tmp_path / "camera.sock")
    server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    server.bind(path)
    server.listen(1)
    done = threading.Event()

    def rig() -> None:
        client, _ = server.accept()
        with client:
            frame = RgbdFrame(0, 1.0, counter_view.rgb, counter_view.depth, counter_view.intrinsics)
            while not done.wait(0.05):
                client.sendall(encode_frame(frame))
        server.close()  # the rig's process is gone

    thread = threading.Thread(target=rig, daemon=True)
    thread.start()
    camera = RealSenseCamera(RigFrameSource(path), stall_after_s=0.5)
    camera.start()
    try:
        image = wait(camera.latest)
        assert np.array_equal(image.rgb, counter_view.rgb) and image.intrinsics.fx == pytest.approx(
            counter_view.intrinsics.fx
        )
        valid = (image.depth > 0) & (counter_view.depth > 0)
        assert np.mean(np.abs(image.depth[valid] - counter_view.depth[valid]) < 0.002) > 0.95
        done.set()  # the rig stops
        thread.join(timeout=5)
        said = wait(lambda: (p := camera.problem()) and ("ended" in p or "no camera stream" in p) and p)
        assert str(tmp_path) in said  # it names where the stream was
    finally:
        done.set()
        camera.stop()
        server.close()


def test_a_camera_stream_that_is_not_frames_is_refused_and_a_cut_one_ends(counter_view) -> None:
    import io

    from robot.sensors.rgbd_stream import RgbdFrame, encode_frame, read_frame

    with pytest.raises(ValueError, match="not an RGB-D frame stream"):
        read_frame(io.BytesIO(b"HTTP/1.1 200 OK\r\n" * 4))
    whole = encode_frame(RgbdFrame(7, 2.5, counter_view.rgb, counter_view.depth, counter_view.intrinsics))
    frame = read_frame(io.BytesIO(whole))
    assert frame is not None and frame.seq == 7 and frame.stamp_s == 2.5
    assert np.array_equal(frame.rgb, counter_view.rgb)
    assert np.abs(frame.depth_m - counter_view.depth).max() <= 0.0005 + 1e-6  # 1 mm counts
    assert read_frame(io.BytesIO(whole[: len(whole) // 2])) is None  # the stream cut mid-frame: its end
