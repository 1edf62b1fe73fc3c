"""Checks of what the robot plugs into: the Dynamixel bus's serial device (the U2D2) and its latency timer, the
microphone and speaker, and offscreen rendering (MuJoCo's EGL or OSMesa, which the head camera uses)."""

from __future__ import annotations

import grp
import os
import stat
import subprocess
import sys
from pathlib import Path

from app.deploy.doctor.report import Check, Level, Machine, ok

RENDER_PROBE = """
import time, robot, mujoco
model = mujoco.MjModel.from_xml_string('<mujoco><worldbody><light pos="0 0 1"/><geom size=".1"/></worldbody></mujoco>')
start = time.perf_counter()
renderer = mujoco.Renderer(model, 64, 64)
data = mujoco.MjData(model)
mujoco.mj_forward(model, data)
renderer.update_scene(data)
image = renderer.render()
print(f"{image.shape[1]}x{image.shape[0]} in {(time.perf_counter() - start) * 1000:.0f} ms")
"""


def _serial_in_use(machine: Machine) -> tuple[bool, str]:
    """(is the real robot served, the device): problems are errors with the dynamixel backend, warnings when a
    robot configuration exists but the simulator is served, and nothing to check otherwise."""
    settings = machine.settings
    used = settings.backend == "dynamixel"
    configured = used or bool(settings.dynamixel_port) or Path(settings.robot_config).exists()
    return configured and used, settings.hardware_config().port if configured else ""


def check_serial(machine: Machine) -> Check:
    used, device = _serial_in_use(machine)
    if not device:
        return ok("serial port", "not used: the simulator is served and there is no robot.toml")
    level = Level.ERROR if used else Level.WARN
    if not os.path.exists(device):
        return Check(
            "serial port",
            level,
            f"{device} does not exist: is the U2D2 plugged in and powered?",
            "plug it in (`ls /dev/serial/by-id/` names it), or set bus.port in robot.toml / HUMANOID_DYNAMIXEL_PORT",
        )
    info = os.stat(device)
    if not stat.S_ISCHR(info.st_mode):
        return Check(
            "serial port",
            level,
            f"{device} is not a character device (a serial port is one)",
            "set bus.port in robot.toml to the U2D2's device, e.g. /dev/ttyUSB0",
        )
    if machine.access(device, os.R_OK | os.W_OK):
        return ok("serial port", f"{device}: {machine.user()} may read and write it")
    try:
        group = grp.getgrgid(info.st_gid).gr_name
    except KeyError:
        group = str(info.st_gid)
    user = machine.user()
    member = user in grp.getgrgid(info.st_gid).gr_mem if group != str(info.st_gid) else False
    if member and group not in machine.groups():
        fix = f"{user} joined {group} after logging in: log out and in again (or: newgrp {group})"
    else:
        fix = (
            f"sudo usermod -aG {group} {user}, then log in again (the service is given {group} by its unit's "
            "SupplementaryGroups)"
        )
    return Check(
        "serial port",
        level,
        f"{device} (mode {stat.S_IMODE(info.st_mode):o}, group {group}): {user} may not read and write it",
        fix,
    )


def check_latency_timer(machine: Machine) -> Check:
    used, device = _serial_in_use(machine)
    if not device:
        return ok("latency timer", "not used: no U2D2 configured")
    if not os.path.exists(device):
        return Check(
            "latency timer",
            Level.ERROR if used else Level.WARN,
            f"{device} does not exist: not checked",
            "plug the U2D2 in, then run humanoid doctor again",
        )
    name = Path(os.path.realpath(device)).name
    timer = machine.sys_root / "bus/usb-serial/devices" / name / "latency_timer"
    if not timer.exists():
        return ok("latency timer", f"{device} ({name}) has no latency timer: not an FTDI USB adapter")
    wanted = machine.settings.hardware_config().latency_timer_ms
    value = float(timer.read_text().strip())
    if value <= wanted:
        return ok("latency timer", f"{name}: {value:g} ms")
    return Check(
        "latency timer",
        Level.WARN,
        f"{name}: {value:g} ms, not {wanted:g} ms: each reply the bus waits for can take {2 * value + 2:g} ms",
        f"echo {wanted:g} | sudo tee {timer}; for good (a udev rule): sudo .venv/bin/humanoid service install",
    )


def check_audio(machine: Machine) -> Check:
    from robot.speech.devices import find_device

    settings = machine.settings
    microphone = find_device("input", settings.microphone)
    speaker = find_device("output", settings.speaker)
    found = [d.describe() for d in (microphone, speaker)]
    if "PortAudio" in microphone.problem:
        return Check("audio", Level.ERROR, microphone.problem, "sudo apt-get install libportaudio2")
    missing = [
        d
        for d, setting in ((microphone, settings.microphone), (speaker, settings.speaker))
        if not d.available and setting.strip().lower() != "off"
    ]
    if not missing:
        return ok("audio", "; ".join(found))
    return Check(
        "audio",
        Level.WARN,
        "; ".join(found) + ": the robot cannot hear or speak (the page's recordings still work)",
        "plug in a USB microphone and speaker (`arecord -l`, `aplay -l` list them; the user needs the audio "
        "group), name one with HUMANOID_MICROPHONE / HUMANOID_SPEAKER, or set them to off",
    )


def _render(gl: str, timeout_s: float) -> tuple[bool, str]:
    env = {**os.environ, "MUJOCO_GL": gl}
    if gl == "osmesa":
        env["PYOPENGL_PLATFORM"] = "osmesa"
    try:
        done = subprocess.run(
            [sys.executable, "-c", RENDER_PROBE], capture_output=True, text=True, env=env, timeout=timeout_s
        )
    except subprocess.TimeoutExpired:
        return False, f"no frame within {timeout_s:.0f} s"
    if done.returncode == 0:
        return True, done.stdout.strip()
    last = (done.stderr.strip().splitlines() or [f"exit code {done.returncode}"])[-1]
    return False, last


def check_rendering(machine: Machine) -> Check:
    """A frame rendered offscreen in a fresh process (MUJOCO_GL is read once, when mujoco is first imported)."""
    gl = os.environ.get("MUJOCO_GL", "egl")
    timeout_s = max(machine.timeout_s, 60.0)  # importing mujoco on a busy computer
    rendered, detail = _render(gl, timeout_s)
    if rendered:
        return ok("rendering", f"MUJOCO_GL={gl}: rendered {detail} offscreen (the head camera's way)")
    settings = machine.settings
    needed = settings.backend == "sim" and settings.perception
    other = "osmesa" if gl != "osmesa" else "egl"
    works, _ = _render(other, timeout_s)
    fix = (
        f"MUJOCO_GL={other} renders here: set it for the app"
        if works
        else "sudo apt-get install libegl1 (or libosmesa6 with MUJOCO_GL=osmesa); on a Jetson the user needs the "
        "video group for the GPU"
    )
    return Check(
        "rendering",
        Level.ERROR if needed else Level.WARN,
        f"MUJOCO_GL={gl} cannot render offscreen ({detail}): the simulated head camera needs it",
        fix,
    )
