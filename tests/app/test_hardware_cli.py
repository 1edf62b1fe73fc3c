"""`humanoid hardware init-config | check | calibrate` against the bus emulator."""

from __future__ import annotations

import json

import pytest

from app.cli.commands import main
from robot.hardware.bus_emulator import BusEmulator
from robot.hardware.config import load_config

IDS = list(range(1, 25))


@pytest.fixture
def robot_toml(tmp_path, monkeypatch):
    path = tmp_path / "robot.toml"
    monkeypatch.setenv("HUMANOID_ROBOT_CONFIG", str(path))
    from app.settings import get_settings

    get_settings.cache_clear()
    yield path
    get_settings.cache_clear()


def test_init_check_and_calibrate(robot_toml, capsys) -> None:
    # r_knee (id 13) and head_pan (id 19) stand off their servos' centres, as assembled
    with BusEmulator(IDS, baudrate=2_000_000, positions={13: 0.2, 19: -0.1}) as emulator:
        assert main(["hardware", "init-config", "--port", emulator.port_name]) == 0
        assert load_config(robot_toml).port == emulator.port_name
        assert main(["hardware", "init-config"]) == 1  # not overwritten without --force
        capsys.readouterr()

        assert main(["hardware", "check", "--json"]) == 0
        report = json.loads(capsys.readouterr().out)
        assert report["answered"] == 24 and all(s["model"] == 1020 for s in report["servos"])
        assert report["bus_utilisation"] < 0.8 and report["fits"]

        assert main(["hardware", "calibrate", "--yes"]) == 0
        offsets = {j.joint: j.offset_rad for j in load_config(robot_toml).joints}
        assert offsets["r_knee"] == pytest.approx(0.2, abs=0.002)
        assert offsets["head_pan"] == pytest.approx(-0.1, abs=0.002)
        assert abs(offsets["l_knee"]) < 0.002

        emulator.set_fault(7, dead=True)
        capsys.readouterr()
        assert main(["hardware", "check"]) == 1
        assert "missing" in capsys.readouterr().out


def test_check_finds_the_sensor_boards_and_reads_the_imu(robot_toml, capsys, monkeypatch) -> None:
    import math

    from robot.sensors.imu import quat_from_rpy

    monkeypatch.setenv("HUMANOID_IMU", "opencr")
    monkeypatch.setenv("HUMANOID_FEET", "fsr")
    from app.settings import get_settings

    get_settings.cache_clear()
    with BusEmulator(IDS, baudrate=2_000_000, sensors=True) as emulator:
        assert main(["hardware", "init-config", "--port", emulator.port_name]) == 0
        emulator.sense_imu(quat_from_rpy(math.radians(5), 0.0, 0.0), [0, 0, 0], [0, 0.85, 9.77])
        emulator.sense_foot(112, [4.0, 4.0, 4.0, 4.0])
        capsys.readouterr()
        assert main(["hardware", "check", "--json"]) == 0
        report = json.loads(capsys.readouterr().out)
        assert [b["found"] for b in report["sensor_boards"]] == [True, True, True]
        assert report["imu_tilt_deg"] == pytest.approx(5.0, abs=0.2)
        assert report["foot_forces_n"][0] == [4.0, 4.0, 4.0, 4.0]
        emulator.set_fault(111, dead=True)
        assert main(["hardware", "check"]) == 1
        assert "right foot FSR   missing" in capsys.readouterr().out
