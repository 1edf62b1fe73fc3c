"""A userspace Ethernet link between two interfaces, impaired as a real network is: every frame is held for a
one-way delay with jitter (in order: a frame never overtakes the one before it, as on a wire), some are lost at
random, and the whole link can be cut and restored. This kernel has no netem qdisc, so the delay and the loss are
made here; the rate limit is the kernel's own `tbf` qdisc on the interface the frames leave by
(see `harness.impaired_link`, which runs this module in a network namespace of its own).

Times are wall-clock (each frame's delay runs from the kernel's stamp of its arrival); the stats say how late,
at worst, frames left after their time (how faithful the link was on a busy machine).

Run as `python -m harness.frame_forwarder LEFT RIGHT [--delay-ms ..]` (root: raw sockets). It prints
{"ready": true} once both interfaces are open, then takes one command a line on stdin and answers each with one
JSON line on stdout: "cut", "restore" (each answered with the wall time it took effect), "stats" (frames and
bytes each way), "quit".
"""

from __future__ import annotations

import argparse
import collections
import contextlib
import json
import os
import random
import selectors
import socket
import struct
import sys
import time
from dataclasses import asdict, dataclass, field

ETH_P_ALL = 0x0003
ETH_P_ARP = 0x0806
SOL_PACKET = 263
PACKET_IGNORE_OUTGOING = 23  # Linux >= 4.20: our own sends are not read back
PACKET_OUTGOING = 4  # the pkttype of a frame this host sent (read back on older kernels)
MAX_FRAME_BYTES = 65536
SOCKET_BUFFER_BYTES = 4 << 20
SO_TIMESTAMPNS = 35  # each frame's kernel arrival time (CLOCK_REALTIME), as a struct timespec
TIMESPEC = struct.Struct("@qq")
ANCILLARY_BYTES = socket.CMSG_SPACE(TIMESPEC.size)


@dataclass(frozen=True)
class Impairment:
    """What one direction of the link does to frames."""

    delay_s: float = 0.020
    jitter_s: float = 0.005  # the delay of each frame is uniform in delay +- jitter
    loss: float = 0.01  # probability that a frame (other than ARP) is lost


@dataclass
class DirectionStats:
    frames: int = 0  # delivered
    bytes: int = 0  # delivered, Ethernet frames whole
    lost: int = 0  # dropped at random
    cut: int = 0  # dropped because the link was cut (arriving then, or in flight when it was cut)
    refused: int = 0  # the outgoing interface refused it (its rate limiter's queue was full)
    late_over_5_ms: int = 0  # frames sent more than 5 ms after their time (this process was not running)
    late_ms_max: float = 0.0


class DelayLine:
    """One direction's frames in flight. A frame arriving at t leaves at max(the previous frame's departure,
    t + delay + jitter): delayed, jittered, never reordered."""

    def __init__(self, impairment: Impairment, rng: random.Random) -> None:
        self._impairment = impairment
        self._rng = rng
        self._queue: collections.deque[tuple[float, bytes]] = collections.deque()
        self._last_departure = float("-inf")

    def admit(self, frame: bytes, arrived_s: float) -> bool:
        """Queue `frame` (True), or lose it at random (False). ARP always passes: a link that loses address
        resolution stalls for seconds, which no real 1 % loss does."""
        if not is_arp(frame) and self._rng.random() < self._impairment.loss:
            return False
        jitter = self._rng.uniform(-self._impairment.jitter_s, self._impairment.jitter_s)
        departure = max(self._last_departure, arrived_s + self._impairment.delay_s + jitter)
        self._last_departure = departure
        self._queue.append((departure, frame))
        return True

    def due(self, now_s: float) -> list[tuple[float, bytes]]:
        """The frames whose departure time has come, in order, with how late each is (s)."""
        out = []
        while self._queue and self._queue[0][0] <= now_s:
            departure, frame = self._queue.popleft()
            out.append((now_s - departure, frame))
        return out

    def next_departure(self) -> float | None:
        return self._queue[0][0] if self._queue else None

    def clear(self) -> int:
        """Drop everything in flight (the link was cut); how many frames that was."""
        dropped = len(self._queue)
        self._queue.clear()
        return dropped


def is_arp(frame: bytes) -> bool:
    return len(frame) >= 14 and int.from_bytes(frame[12:14], "big") == ETH_P_ARP


@dataclass
class _Direction:
    name: str
    source: socket.socket
    sink: socket.socket
    line: DelayLine
    stats: DirectionStats = field(default_factory=DirectionStats)


def arrival_time(ancillary: list[tuple[int, int, bytes]]) -> float:
    """When the kernel received the frame (its SO_TIMESTAMPNS stamp), else now: a frame's delay runs from its
    arrival, not from when this process got round to reading it."""
    for level, kind, data in ancillary:
        if level == socket.SOL_SOCKET and kind == SO_TIMESTAMPNS and len(data) >= TIMESPEC.size:
            seconds, nanoseconds = TIMESPEC.unpack_from(data)
            return seconds + nanoseconds * 1e-9
    return time.time()


def open_raw(interface: str) -> socket.socket:
    """A raw socket on `interface` that reads every frame it receives (and not those we send on it)."""
    sock = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.htons(ETH_P_ALL))
    with contextlib.suppress(OSError):  # older kernels: frames we sent are read back and skipped by their pkttype
        sock.setsockopt(SOL_PACKET, PACKET_IGNORE_OUTGOING, 1)
    sock.setsockopt(socket.SOL_SOCKET, SO_TIMESTAMPNS, 1)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, SOCKET_BUFFER_BYTES)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, SOCKET_BUFFER_BYTES)
    sock.bind((interface, 0))
    sock.setblocking(False)
    return sock


class Forwarder:
    """Moves frames both ways between two interfaces through a delay line each, until told to quit."""

    def __init__(self, left: str, right: str, impairment: Impairment, seed: int) -> None:
        rng = random.Random(seed)
        a, b = open_raw(left), open_raw(right)
        # left -> right and right -> left, each with its own random stream (same seed, same run)
        self._directions = [
            _Direction(f"{left}->{right}", a, b, DelayLine(impairment, random.Random(rng.random()))),
            _Direction(f"{right}->{left}", b, a, DelayLine(impairment, random.Random(rng.random()))),
        ]
        self._cut = False
        self._commands = b""  # what came on stdin, up to its last complete line
        self._selector = selectors.DefaultSelector()
        for direction in self._directions:
            self._selector.register(direction.source, selectors.EVENT_READ, direction)
        self._selector.register(sys.stdin.fileno(), selectors.EVENT_READ, None)

    def run(self) -> None:
        _answer({"ready": True, "directions": [d.name for d in self._directions]})
        while True:
            timeout = self._until_next_departure()
            for key, _ in self._selector.select(timeout):
                if key.data is None:
                    if not self._read_commands():
                        return
                else:
                    self._receive(key.data)
            now = time.time()
            for direction in self._directions:
                for late_s, frame in direction.line.due(now):
                    self._send(direction, frame, late_s)

    def _until_next_departure(self) -> float | None:
        departures = [t for d in self._directions if (t := d.line.next_departure()) is not None]
        return max(0.0, min(departures) - time.time()) if departures else None

    def _receive(self, direction: _Direction) -> None:
        while True:
            try:
                frame, ancillary, _, address = direction.source.recvmsg(MAX_FRAME_BYTES, ANCILLARY_BYTES)
            except BlockingIOError:
                return
            if address[2] == PACKET_OUTGOING:
                continue
            if self._cut:
                direction.stats.cut += 1
            elif not direction.line.admit(frame, arrival_time(ancillary)):
                direction.stats.lost += 1

    def _send(self, direction: _Direction, frame: bytes, late_s: float) -> None:
        """Send a frame whose time has come (`late_s` after it: how faithful the delay was)."""
        stats = direction.stats
        stats.late_ms_max = max(stats.late_ms_max, round(late_s * 1e3, 2))
        stats.late_over_5_ms += late_s > 0.005
        try:
            direction.sink.send(frame)
        except OSError:  # ENOBUFS: the rate limiter's queue is full, the frame is dropped there
            direction.stats.refused += 1
            return
        direction.stats.frames += 1
        direction.stats.bytes += len(frame)

    def _read_commands(self) -> bool:
        """Obey the complete lines on stdin; False once told to quit (or stdin closed: whoever started us is
        gone)."""
        data = os.read(sys.stdin.fileno(), 4096)
        if not data:
            return False
        self._commands += data
        *lines, self._commands = self._commands.split(b"\n")
        return all(self._command(line.decode(errors="replace").strip()) for line in lines)

    def _command(self, command: str) -> bool:
        if not command:
            return True
        if command == "quit":
            return False
        if command == "cut":
            self._cut = True
            for direction in self._directions:
                direction.stats.cut += direction.line.clear()
            _answer({"cut": True, "wall_time_s": time.time()})
        elif command == "restore":
            self._cut = False
            _answer({"cut": False, "wall_time_s": time.time()})
        elif command == "stats":
            _answer(
                {
                    "cut": self._cut,
                    "wall_time_s": time.time(),
                    "directions": {d.name: asdict(d.stats) for d in self._directions},
                }
            )
        else:
            _answer({"error": f"unknown command {command!r}: cut, restore, stats or quit"})
        return True


def _answer(message: dict) -> None:
    sys.stdout.write(json.dumps(message) + "\n")
    sys.stdout.flush()


def run_as_the_wire() -> None:
    """A wire is not a program that waits for the cores like those it carries: on a loaded machine this process
    runs first (real-time priority, the lowest; it sleeps between frames and uses a few % of a core), else at a
    raised priority; how late frames still left is in the stats."""
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(1))
    except (OSError, AttributeError):
        with contextlib.suppress(OSError):
            os.setpriority(os.PRIO_PROCESS, 0, -10)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("left", help="interface of one side (e.g. the server's)")
    parser.add_argument("right", help="interface of the other side (e.g. the operator's)")
    parser.add_argument("--delay-ms", type=float, default=20.0, help="one-way delay")
    parser.add_argument("--jitter-ms", type=float, default=5.0, help="the delay varies by up to this, either way")
    parser.add_argument("--loss", type=float, default=0.01, help="probability that a frame is lost")
    parser.add_argument("--seed", type=int, default=0, help="seed of the jitter and the losses")
    args = parser.parse_args(argv)
    run_as_the_wire()
    impairment = Impairment(args.delay_ms / 1e3, args.jitter_ms / 1e3, args.loss)
    Forwarder(args.left, args.right, impairment, args.seed).run()
    return 0


if __name__ == "__main__":
    sys.exit(main())
