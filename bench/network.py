"""`humanoid bench network`: the console used over a poor network, not loopback (issue 36).

The real server (`humanoid serve`, access control on, bound to its namespace's address) runs on one side of
`harness.impaired_link` (20 +- 5 ms each way, 1 % of frames lost, 2 Mbit/s towards the operator) and the
operator's and viewers' clients (`harness.network_client`, programs of their own) on the other. Measured:

- the link's round trip (a ping on the e-stop's idle socket, and on `/ws` behind the state stream, as the page's
  badge sees it);
- e-stop latency, from the client's press (its `client_time_s`) to the control loop applying the stop (the
  robot's `estop/latched` event), over many presses: sent as the page sends it (on `/ws` and `/ws/stop`), and on
  `/ws` alone for comparison (a segment lost on one TCP connection waits for its resend);
- while driving by teleop at 10 Hz, the time from cutting the link to the robot beginning to stop (the wall time
  of the deadman's event, seen on the server's side, minus the moment the wire was cut), over several cuts;
- per viewer at default settings (`/ws`, `/ws/camera` and the light 3D view, as a page opens them): the bytes/s
  the server sends it and the state rate it receives, over the link, and what the same viewer is sent with no
  link in between (what the server wants to send, which the 2 Mbit/s limit would otherwise hide).

Needs root (network namespaces); without it the result says why it was skipped.
"""

from __future__ import annotations

import os
import platform
import tempfile
import time
from pathlib import Path
from typing import Any

from app.settings import Settings
from harness.impaired_link import ImpairedLink, LinkProfile, unavailable_reason
from harness.network_rig import Ends, cut_while_driving, estop_presses, read_line, round_trips, served_across
from robot.perception.service import SENSOR_HZ

TARGETS = {
    "estop_p99_ms": 60.0,
    "cut_to_stopping_max_ms": 400.0,  # teleop's 300 ms deadman + 100 ms
    "viewer_mbit_s": 2.0,
    "viewer_state_rate_of_no_link": 0.95,  # the state rate holds over the link (as a share of the unlinked viewer's)
}
STATE_HZ = Settings.model_fields["ws_state_hz"].default  # what a page is sent at default settings
# full Ethernet frames for full TCP segments (MSS 1448 with timestamps); what a viewer's page reads, on the wire
# (from the wire's own count instead, a client that reads late moves bytes between windows)
WIRE_OVERHEAD = 1514 / 1448
VIEWER_SETTLE_S = 8.0  # a viewer's first scene and camera frames, before its steady rate is measured


def viewers_side_by_side(ends: Ends, link: ImpairedLink, settle_s: float, seconds: float) -> dict[str, Any]:
    """A viewer across the link and one on the server's side (the same page with nothing in between: what the
    server sends when no link limits it), watched together while an operator on the server's side drives (a robot
    that moves is what makes the 3D view and the camera send the most). Over the link, the wire's own count of the
    bytes to the viewer too."""
    driver = ends.local_operator.start(
        "drive", "--vx", "0", "--yaw-rate", "0.4"
    )  # (on the spot: it walks into nothing)
    args = ("--settle", str(settle_s), "--seconds", str(seconds))
    remote, local = ends.viewer.start("view", *args), ends.on_server.start("view", *args)
    try:
        read_line(remote, settle_s + 120)  # {"measuring": true}
        before, started = link.counters(), time.monotonic()
        over = read_line(remote, seconds + 60)
        after, window = link.counters(), time.monotonic() - started
        read_line(local, settle_s + 120)
        demand = read_line(local, seconds + 60)
    finally:
        for process in (remote, local):
            process.wait(timeout=30)
        drive = ends.local_operator.stop("drive", driver)
    for result in (over, demand):
        result["mbit_s"] = round(result["bytes_per_s"] * 8 / 1e6, 3)
    down = after["server_to_operator"]["bytes"] - before["server_to_operator"]["bytes"]
    dropped = after["rate_limiter"]["drops"] - before["rate_limiter"]["drops"]
    over["wire"] = {"mbit_s": round(down * 8 / window / 1e6, 3), "frames_dropped_at_the_limit": dropped}
    return {
        "over_the_link": over,
        "no_link": demand,
        "at_nominal_rates": at_nominal_rates(demand),
        "while": f"driven from the server's side: {drive}",
    }


def at_nominal_rates(viewer: dict[str, Any]) -> dict[str, float]:
    """What `viewer` would be sent if the state and the camera ran at their nominal rates (a loaded machine sends
    fewer of both, which would flatter the figure), on the wire (TCP/IP and Ethernet headers included)."""
    streams = viewer["streams"]
    per_state = streams["robot"]["bytes_per_s"] / viewer["state_hz"] if viewer["state_hz"] else 0.0
    per_frame = streams["camera"]["bytes_per_s"] / viewer["camera_fps"] if viewer["camera_fps"] else 0.0
    app_bytes = per_state * STATE_HZ + per_frame * SENSOR_HZ + streams["scene"]["bytes_per_s"]
    return {
        "state_hz": STATE_HZ,
        "camera_fps": SENSOR_HZ,
        "state_kb_each": round(per_state / 1e3, 2),  # (with the diagnostics and events that come between)
        "camera_kb_per_frame": round(per_frame / 1e3, 2),
        "mbit_s": round(app_bytes * 8 * WIRE_OVERHEAD / 1e6, 3),
    }


def run_network(presses: int = 100, cuts: int = 6, viewer_seconds: float = 20.0, seed: int = 0) -> dict[str, Any]:
    profile = LinkProfile(seed=seed)
    result: dict[str, Any] = {
        "suite": "network",
        "machine": {"cpus": os.cpu_count(), "python": platform.python_version(), "platform": platform.platform()},
        "config": {
            "link": {
                "delay_ms": profile.delay_ms,
                "jitter_ms": profile.jitter_ms,
                "loss": profile.loss,
                "rate_kbit_to_operator": profile.rate_kbit,
                "rate_queue_ms": profile.rate_queue_ms,
                "seed": seed,
            },
            "presses": presses,
            "cuts": cuts,
            "viewer": "/ws + /ws/camera + the light 3D view, default settings",
            "access_control": "on (API tokens)",
        },
        "targets": TARGETS,
    }
    if reason := unavailable_reason():
        return {**result, "skipped": reason}
    started, load_before = time.monotonic(), os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp, ImpairedLink(profile) as link, served_across(link, Path(tmp)) as ends:
        result["rtt_ms"] = {
            "e_stop_socket": round_trips(ends.operator, "/ws/stop", 100),
            "page_socket": round_trips(ends.operator, "/ws", 50),
        }
        result["estop"] = {
            "as_the_page": estop_presses(ends.operator, presses, ws_only=False, seed=seed),
            "ws_only": estop_presses(ends.operator, presses, ws_only=True, seed=seed + 1),
        }
        result["teleop_cut"] = cut_while_driving(link, ends.operator, ends.watch, cuts)
        result["viewer"] = viewers_side_by_side(ends, link, VIEWER_SETTLE_S, viewer_seconds)
        result["link_counters"] = link.counters()
        result["incidents"] = ends.watch.incidents
    result["elapsed_s"] = round(time.monotonic() - started, 1)
    # (other work on the machine delays both ends: a figure missed under load is checked on an idle machine)
    result["machine"]["load_average_1min"] = {"before": load_before[0], "after": os.getloadavg()[0]}
    cut = result["teleop_cut"]
    over, demand, nominal = (result["viewer"][k] for k in ("over_the_link", "no_link", "at_nominal_rates"))
    result["pass"] = {
        "estop_p99": result["estop"]["as_the_page"]["latency_ms"]["p99"] <= TARGETS["estop_p99_ms"]
        and result["estop"]["as_the_page"]["missed"] == 0,
        "cut_to_stopping": None not in cut["cut_to_stopping_ms"] and cut["max_ms"] <= TARGETS["cut_to_stopping_max_ms"],
        "viewer_bandwidth": max(demand["mbit_s"], over["wire"]["mbit_s"], nominal["mbit_s"])
        <= TARGETS["viewer_mbit_s"],
        "viewer_state_rate": over["state_hz"] >= TARGETS["viewer_state_rate_of_no_link"] * demand["state_hz"],
        # the robot neither fell, stopped itself (a control loop starved on a loaded machine) nor restarted
        "no_incidents": not result["incidents"],
    }
    return result
