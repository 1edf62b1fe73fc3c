"""The impaired link's delay line: frames are delayed within the jitter, never reordered, lost at the given rate
(reproducibly for a seed), ARP never lost, and a cut drops what is in flight."""

from __future__ import annotations

import random

from harness.frame_forwarder import ETH_P_ARP, DelayLine, Impairment

DELAY = Impairment(delay_s=0.020, jitter_s=0.005, loss=0.0)


def frame(n: int, ethertype: int = 0x0800) -> bytes:
    return bytes(12) + ethertype.to_bytes(2, "big") + n.to_bytes(4, "big")


def test_frames_far_apart_are_delayed_by_the_delay_give_or_take_the_jitter() -> None:
    line = DelayLine(DELAY, random.Random(1))
    delays = []
    for n in range(500):
        arrived = n * 1.0  # (far apart: no frame waits behind another)
        assert line.admit(frame(n), arrived)
        departure = line.next_departure()
        assert [f for _, f in line.due(arrived + 1.0)] == [frame(n)]
        delays.append(departure - arrived)
    assert min(delays) >= 0.015 - 1e-9
    assert max(delays) <= 0.025 + 1e-9
    assert max(delays) - min(delays) > 0.008  # the jitter is there, not a fixed delay


def test_frames_close_together_leave_in_order_and_none_before_its_time() -> None:
    line = DelayLine(DELAY, random.Random(2))
    arrivals = [n * 0.0005 for n in range(400)]  # 2000 frames/s: much closer than the jitter
    for n, t in enumerate(arrivals):
        line.admit(frame(n), t)
    out, now = [], 0.0
    while line.next_departure() is not None:
        now += 0.001
        for late, f in line.due(now):
            n = int.from_bytes(f[14:18], "big")
            assert now >= arrivals[n] + 0.015  # never early
            assert 0.0 <= late < 0.001 + 1e-9  # (and said how late, here at most the step)
            out.append(n)
    assert out == list(range(400))


def test_loss_is_at_the_rate_asked_and_the_same_for_the_same_seed() -> None:
    lossy = Impairment(delay_s=0.02, jitter_s=0.005, loss=0.05)

    def losses(seed: int) -> list[int]:
        line = DelayLine(lossy, random.Random(seed))
        return [n for n in range(20000) if not line.admit(frame(n), n * 0.001)]

    first = losses(7)
    assert 0.04 < len(first) / 20000 < 0.06
    assert losses(7) == first
    assert losses(8) != first


def test_arp_is_never_lost() -> None:
    line = DelayLine(Impairment(loss=1.0), random.Random(0))
    assert all(line.admit(frame(n, ETH_P_ARP), n * 0.001) for n in range(100))
    assert not line.admit(frame(100), 0.1)


def test_a_cut_drops_what_is_in_flight() -> None:
    line = DelayLine(DELAY, random.Random(3))
    for n in range(5):
        line.admit(frame(n), 0.0)
    assert line.clear() == 5
    assert line.next_departure() is None
    assert line.due(10.0) == []
