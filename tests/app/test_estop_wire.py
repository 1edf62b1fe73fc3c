"""scripts/estop_wire.py splits a browser e-stop at its first packet on the wire: the split of a known press."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "estop_wire.py"


@pytest.fixture(scope="module")
def wire():
    spec = importlib.util.spec_from_file_location("estop_wire", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)  # type: ignore[union-attr]
    return module


def test_a_press_is_split_at_its_first_data_segment_on_the_wire(wire) -> None:
    # pressed at 100.000; the handler ran 4 ms later; the first segment left 6 ms after that; the server took it
    # 30 ms later; the control loop applied it 2 ms after that
    event = {
        "wall_time_s": 100.042,
        "data": {"latency_ms": 42.0, "server_latency_ms": 2.0, "source": "browser"},
    }
    lines = [
        "100.001000 IP 127.0.0.1.40000 > 127.0.0.1.8000: Flags [P.], seq 1:27, ack 1, win 512, length 26",
        "100.005000 IP 127.0.0.1.40002 > 127.0.0.1.8000: Flags [.], ack 9, win 512, length 0",  # no data
        "100.010000 IP 127.0.0.1.40002 > 127.0.0.1.8000: Flags [P.], seq 1:55, ack 1, win 512, length 54",
        "100.011000 IP 127.0.0.1.40004 > 127.0.0.1.8000: Flags [P.], seq 1:55, ack 1, win 512, length 54",
        "tcpdump: a line that is no packet",
    ]
    (press,) = wire.split_presses([event], [4.0], wire._packets(lines))
    assert press["in_page_ms"] == 4.0 and press["first_path"] == "browser"
    assert press["handler_to_wire_ms"] == pytest.approx(6.0, abs=1e-6)
    assert press["wire_to_server_ms"] == pytest.approx(30.0, abs=1e-6)
    assert press["server_to_applied_ms"] == 2.0
    # a press whose packets were not captured is said as such, not given a made-up split
    (lost,) = wire.split_presses([event], [4.0], [])
    assert lost["handler_to_wire_ms"] is None and lost["wire_to_server_ms"] is None
