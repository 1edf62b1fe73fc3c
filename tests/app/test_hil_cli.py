"""`humanoid hil`: the rig from the command line, found by the real robot's own tools through the configuration it
writes, and stopped cleanly."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

from robot.hardware.config import load_config
from robot.model.world import generate_world


def test_the_rig_writes_its_configuration_and_hardware_check_finds_the_robot_on_it(tmp_path) -> None:
    config = tmp_path / "hil.toml"
    rig = subprocess.Popen(
        [sys.executable, "-m", "app.cli", "hil", "--seed", "2", "--write-config", str(config)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        deadline = time.monotonic() + 120
        while not config.exists():
            assert rig.poll() is None, rig.communicate()
            assert time.monotonic() < deadline, "the rig did not write its configuration"
            time.sleep(0.1)
        wired = load_config(config)
        assert wired.imu == "opencr" and wired.feet == "fsr" and wired.port.startswith("/dev/")

        check = subprocess.run(
            [sys.executable, "-m", "app.cli", "hardware", "check", "--config", str(config), "--json"],
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert check.returncode == 0, check.stderr
        report = json.loads(check.stdout)
        assert report["answered"] == report["expected"] == 24
        assert all(board["found"] for board in report["sensor_boards"])
        assert report["imu_tilt_deg"] < 1.0  # upright on its stand
    finally:
        rig.send_signal(signal.SIGTERM)
        out, err = rig.communicate(timeout=60)
    assert rig.returncode == 0, err
    assert f"--robot-config {config} --seed 2" in out and "rig stopped" in out and "upright" in out


def test_bench_walk_through_the_rig_writes_falls_tracking_and_the_ticks_bus_and_compute(tmp_path) -> None:
    out = tmp_path / "hil.json"
    command = ["bench", "walk", "--backend", "hil", "--lockstep", "--scripts", "1", "--script-duration", "4"]
    bench = subprocess.run(
        [sys.executable, "-m", "app.cli", *command, "--output", str(out)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert bench.returncode == 0, bench.stderr
    result = json.loads(out.read_text())
    assert result["backend"] == "hil" and result["falls"] == 0 and len(result["trials"]) == 1
    trial = result["trials"][0]
    assert trial["physics_s"] >= 4.0 and trial["ticks"] > 0
    # the tick's two parts, each measured: the bus's round trip (servos, boards, goals) and the compute
    assert 0 < trial["bus_p50_ms"] <= trial["bus_p99_ms"] and 0 < trial["compute_p50_ms"] <= trial["compute_p99_ms"]
    # and the walk plans that came late (the gait planner shares the cores): counted, with their lateness
    assert trial["late_walk_plans"] >= 0 and (trial["late_walk_plans_s"] > 0) == (trial["late_walk_plans"] > 0)


def test_run_through_the_rig_picks_the_mug_with_the_real_robots_bus_lidar_and_camera(tmp_path) -> None:
    command = ["run", "pick up the red mug from the kitchen counter", "--backend", "hil", "--seed", "3", "--json"]
    run = subprocess.run(
        [sys.executable, "-m", "app.cli", *command],
        capture_output=True,
        text=True,
        timeout=900,
        env={
            **os.environ,
            "DATABASE_URL": f"sqlite:///{tmp_path / 'hil.db'}",
            "HUMANOID_AUDIO_DIR": str(tmp_path / "audio"),
        },
    )
    assert run.returncode == 0, run.stdout + run.stderr
    result = json.loads(run.stdout)
    assert result["success"] and not result["fell"] and result["held_object"] == "red mug"
    # mapped with the lidar, found with the camera, picked with the arm: every step, through the emulated devices
    assert [s["status"] for s in result["steps"]] == ["succeeded"] * 4
    counter = next(p for p in generate_world(3).places if p.name == "kitchen counter")
    mug = result["rig"]["objects"]["red mug"]  # where it really is: in the hand, off the counter
    assert mug[2] > counter.surface.height + 0.03
    assert result["sim_time_s"] > 5.0  # the rig's physics time
