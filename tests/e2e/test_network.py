"""The console across a real (emulated) network: the server in one network namespace, the operator's clients in
another, joined by a link with 20 +- 5 ms each way, 1 % loss and 2 Mbit/s to the operator (`humanoid bench
network` measures the figures; these tests prove the rig carries the console and behaves as a link does)."""

from __future__ import annotations

import contextlib
import time
from collections.abc import Iterator

import pytest

from harness.impaired_link import ImpairedLink, RigUnavailable, unavailable_reason
from harness.network_rig import Ends, cut_while_driving, estop_presses, round_trips, served_across

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def across(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[ImpairedLink, Ends]]:
    if reason := unavailable_reason():
        pytest.skip(f"no network namespaces here: {reason}")
    with contextlib.ExitStack() as stack:
        try:
            link = stack.enter_context(ImpairedLink())
        except RigUnavailable as exc:
            pytest.skip(f"cannot make the network rig: {exc}")
        yield link, stack.enter_context(served_across(link, tmp_path_factory.mktemp("server")))


def test_the_round_trip_is_a_network_s_not_loopback_s(across: tuple[ImpairedLink, Ends]) -> None:
    link, ends = across
    before = link.counters()["operator_to_server"]["frames"]
    rtt = round_trips(ends.operator, "/ws/stop", 20)
    # each way at least 20 - 5 ms: no round trip can be shorter than 30 ms, and the fastest is not far above
    assert 29.0 <= rtt["min"] < 100.0, rtt
    assert link.counters()["operator_to_server"]["frames"] > before  # (through the wire, not another way)


def test_an_estop_sent_across_the_link_latches_the_robot(across: tuple[ImpairedLink, Ends]) -> None:
    _, ends = across
    pressed_at = time.time()
    presses = estop_presses(ends.operator, 1, ws_only=False, seed=0)
    assert presses["latency_ms"]["n"] == 1 and presses["missed"] == 0
    latched = ends.watch.next({"estop/latched"}, pressed_at, 30.0)  # as the robot's own side saw it
    assert latched is not None
    assert latched["data"]["source"] in ("browser", "browser-backup")


def test_cutting_the_link_while_driving_stops_the_robot(across: tuple[ImpairedLink, Ends]) -> None:
    link, ends = across
    result = cut_while_driving(link, ends.operator, ends.watch, cuts=1)
    assert result["cut_to_stopping_ms"][0] is not None, result
    assert result["event_kinds"] == {"teleop/deadman": 1}  # the deadman stopped it, nobody else
    assert result["driver"]["teleop_sent"] > 0
