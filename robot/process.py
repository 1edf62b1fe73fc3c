"""The robot worker (the simulated robot's, or the real robot's with `hardware=`) in its own process, behind the
same `RobotPort` interface.

Why: the web server, the 3D mirror and the browsers' WebSockets all run Python threads; in one process they
compete with the control loop for the interpreter lock and made it miss deadlines. In its own process the control
loop only shares the lock with the robot's own threads.

Wire protocol over one duplex pipe (pickled tuples):
  parent -> child: ("cmd", id, Command) | ("stop",)
  child -> parent: ("ready", RobotDescription, RobotState) | ("reply", id, CommandReply) | ("state", RobotState)
                   | ("event", Event) | ("feed", SensorFeed: only the parts that changed) | ("fatal", str)
                   | ("beat",) (when nothing else was sent for BEAT_PERIOD_S: the child is answering)

The parent never blocks on the child: `submit_async` sends and hands back a future, and a child that has sent
nothing for `UNRESPONSIVE_AFTER_S` and makes no progress (frozen, not dead: stopped, or using no CPU) is said to be
not answering: commands other than the e-stop are refused at once instead of queueing behind it.
"""

from __future__ import annotations

import gc
import itertools
import logging
import multiprocessing as mp
import pickle
import threading
import time
import traceback
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from concurrent.futures import TimeoutError as FutureTimeout
from dataclasses import dataclass
from multiprocessing.connection import Connection
from typing import Any

import psutil

from robot.control.priority import WORKER_FIFO_PRIORITY, raise_thread_priority
from robot.diagnostics.thresholds import Thresholds
from robot.events import EventBus, Subscription
from robot.interface import (
    ApprovePlan,
    CancelPlan,
    Command,
    CommandReply,
    DiagnosticArray,
    EStop,
    Event,
    InjectFault,
    Level,
    OperatorHeartbeat,
    PausePlan,
    PlaceObstacle,
    Refusal,
    ReleaseEStop,
    ResetRobot,
    ResumePlan,
    RobotDescription,
    RobotState,
    SensorFeed,
    SetApproval,
    SetPosture,
    SetTorque,
    StopTeleop,
    Teleop,
)
from robot.planning.config import PlannerConfig
from robot.speech.robot_voice import VoiceConfig
from robot.state_board import StateBoard
from robot.telemetry import TelemetryBatch, TelemetryRing

log = logging.getLogger(__name__)

# State snapshots sent to the parent at up to 50 Hz: its readers (the 3D mirror at 30 Hz, pages at 20 Hz) need no
# more, and each one costs the web server's interpreter lock time to unpickle.
STATE_PERIOD_S = 0.02
# Planning may take a while (an LLM's timeout, then a repair, then the rules); the e-stop never waits behind it.
REPLY_TIMEOUT_S = 90.0
STARTUP_TIMEOUT_S = 180.0
# The child says it is there at least this often (state goes at 50 Hz while anything moves; a beat otherwise).
BEAT_PERIOD_S = 0.1
# Silent this long and making no progress (stopped, or no CPU time used since): the robot process is frozen,
# noticed within a second. A process that is silent but busy (an import holding the interpreter lock, a machine
# so loaded that its threads wait for a core) is slow, not frozen: its commands queue as usual, unless it stays
# silent for BUSY_SILENCE_S (a loop that never lets go).
UNRESPONSIVE_AFTER_S = 0.6
PROGRESS_CPU_S = 0.02  # used in PROGRESS_WINDOW_S: its control loop alone uses more
PROGRESS_WINDOW_S = 0.3
BUSY_SILENCE_S = 15.0
# Commands that must never queue behind a slow one: handled inline by the child's receiving thread.
_IMMEDIATE = (
    EStop,
    ReleaseEStop,
    CancelPlan,
    Teleop,
    StopTeleop,
    SetPosture,
    ResetRobot,
    PlaceObstacle,
    PausePlan,
    ApprovePlan,
    ResumePlan,
    SetApproval,
    InjectFault,
    SetTorque,
    OperatorHeartbeat,
)


# stopped (SIGSTOP, a debugger), or gone while its pipe is still open: no progress to wait for
_STOPPED = (psutil.STATUS_STOPPED, psutil.STATUS_TRACING_STOP, psutil.STATUS_ZOMBIE, psutil.STATUS_DEAD)


def _progress(pid: int | None) -> tuple[str, float]:
    """A process's state and the CPU seconds it has used (its threads together)."""
    try:
        process = psutil.Process(pid)
        with process.oneshot():
            times = process.cpu_times()
            return process.status(), times.user + times.system
    except (psutil.Error, ValueError):
        return psutil.STATUS_DEAD, 0.0


class FreezeWatch:
    """Tells a frozen process (stopped, or silent and using no CPU) from a slow one (silent but busy)."""

    def __init__(
        self,
        probe: Callable[[int | None], tuple[str, float]] = _progress,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self._probe = probe
        self._clock = clock
        self._mark: tuple[float, float, float] | None = None  # (last heard, when first found silent, CPU s then)

    def silent_for_s(self, pid: int | None, last_heard: float) -> float:
        """Seconds since `last_heard` when the process is frozen; 0 while it answers or is silent but busy."""
        now = self._clock()
        silent = now - last_heard
        if silent <= UNRESPONSIVE_AFTER_S:
            return 0.0
        if silent > BUSY_SILENCE_S:
            return silent
        status, cpu_s = self._probe(pid)
        if status in _STOPPED:
            return silent
        if self._mark is None or self._mark[0] != last_heard:  # silent since then: does it use the CPU meanwhile?
            self._mark = (last_heard, now, cpu_s)
            return 0.0
        if now - self._mark[1] < PROGRESS_WINDOW_S:
            return 0.0
        if cpu_s - self._mark[2] < PROGRESS_CPU_S:
            return silent
        self._mark = (last_heard, now, cpu_s)  # busy: judged again over the next window
        return 0.0


@dataclass(frozen=True)
class HardwareSpec:
    """What the child needs to drive the real robot instead of the simulation."""

    config: Any  # robot.hardware.config.HardwareConfig (imported in the child only: dynamixel-sdk is optional)
    deadman_s: float = 1.5


class WorkerProcess:
    """Parent-side proxy of a `RobotWorker` running in a child process."""

    def __init__(
        self,
        seed: int,
        control_hz: float = 100.0,
        realtime: bool = True,
        perception: bool = True,
        planning: PlannerConfig | None = None,
        max_auto_replans: int = 2,
        approve_plans: bool = False,
        voice: VoiceConfig | None = None,
        diagnostics: Thresholds | None = None,
        disk_path: str = ".",
        hardware: HardwareSpec | None = None,
    ) -> None:
        self._hardware = hardware
        self._seed = seed
        self._thresholds = diagnostics
        self._disk_path = disk_path
        self._voice = voice
        self._approve_plans = approve_plans
        self._planning = planning or PlannerConfig()
        self._max_auto_replans = max_auto_replans
        self._perception = perception
        self._control_hz = control_hz
        self._realtime = realtime
        self._bus = EventBus(sim_clock=self._sim_time)
        self._ids = itertools.count(1)
        self._pending: dict[int, Future[CommandReply]] = {}
        self._pending_lock = threading.Lock()
        self._send_lock = threading.Lock()
        self._board = StateBoard()
        self._feed = SensorFeed()
        self._telemetry = TelemetryRing()
        self._diagnostics: DiagnosticArray | None = None
        self._description: RobotDescription | None = None
        self._process: mp.process.BaseProcess | None = None
        self._conn: Connection | None = None
        self._reader: threading.Thread | None = None
        self._alive = False
        self._last_heard = time.monotonic()
        self._freeze = FreezeWatch()
        self._taps: list[Callable[[str, bytes], None]] = []

    # lifecycle -------------------------------------------------------------------------------------------------

    def start(self, latched: EStop | None = None) -> None:
        """Start the robot process; with `latched`, it latches that e-stop before it answers anything."""
        context = mp.get_context("spawn")  # never fork a process that already runs threads
        parent_conn, child_conn = context.Pipe(duplex=True)
        self._process = context.Process(
            target=child_main,
            args=(
                child_conn,
                self._seed,
                self._control_hz,
                self._realtime,
                self._perception,
                self._planning,
                self._max_auto_replans,
                self._approve_plans,
                self._voice,
                self._thresholds,
                self._disk_path,
                self._hardware,
                latched,
            ),
            name="robot-worker",
            daemon=True,
        )
        self._process.start()
        child_conn.close()
        self._conn = parent_conn
        if not parent_conn.poll(STARTUP_TIMEOUT_S):
            self._process.kill()
            raise RuntimeError(f"the robot worker did not start within {STARTUP_TIMEOUT_S:.0f} s")
        try:
            message = parent_conn.recv()
        except EOFError:
            message = ("fatal", f"the process exited with code {self._process.exitcode} before it was ready")
        if message[0] != "ready":
            self._process.join(timeout=5)
            raise RuntimeError(f"the robot worker failed to start:\n{message[1]}")
        _, self._description, initial_state = message
        self._board.publish(initial_state)
        self._last_heard = time.monotonic()
        self._alive = True
        self._reader = threading.Thread(target=self._read, name="robot-worker-reader", daemon=True)
        self._reader.start()

    def restart(self, latched: EStop) -> None:
        """A new robot process in place of a dead one (or one that is killed first), behind this same proxy: its
        subscribers, the mirror and the recorder keep their handles. The new robot starts as at start-up, but with
        `latched` latched before it answers anything (no command can reach it unlatched, not even for a tick);
        what the old one published stays with whoever consumed it, and late joiners start from the new robot."""
        if self._process is not None and self._process.is_alive():
            self._process.kill()
        if self._process is not None:
            self._process.join(timeout=5)
        if self._reader is not None:
            self._reader.join(timeout=2)
        self._process = None
        self._alive = False
        self._bus.clear_history()
        self._telemetry = TelemetryRing()  # the new robot numbers its samples from 0 again
        self._feed = SensorFeed()
        self._diagnostics = None
        self.start(latched)

    def _sim_time(self) -> float:
        try:
            return self._board.latest().sim_time_s
        except RuntimeError:
            return 0.0

    def announce(self, kind: str, message: str, level: Level = Level.OK, **data: Any) -> Event:
        """An event about the robot process itself (it died, it was restarted), numbered with the robot's own."""
        return self._bus.publish(kind, message, level, **data)

    @property
    def pid(self) -> int | None:
        return self._process.pid if self._process is not None else None

    @property
    def exitcode(self) -> int | None:
        """The robot process's exit code once it has ended (negative: killed by that signal)."""
        return self._process.exitcode if self._process is not None else None

    def stop(self) -> None:
        if self._process is None:
            return
        if self._alive:
            try:
                with self._send_lock:
                    self._conn.send(("stop",))  # type: ignore[union-attr]
            except OSError:
                pass
        self._process.join(timeout=10)
        if self._process.is_alive():
            self._process.kill()
            self._process.join(timeout=5)
        self._alive = False
        if self._reader:
            self._reader.join(timeout=2)
        self._process = None

    def is_alive(self) -> bool:
        return self._alive and self._process is not None and self._process.is_alive()

    def silent_for_s(self) -> float:
        """How long the running robot process has not answered, once it is frozen (0 while it answers, while it is
        silent but busy, or when it is not running)."""
        return self._freeze.silent_for_s(self.pid, self._last_heard) if self.is_alive() else 0.0

    # RobotPort -------------------------------------------------------------------------------------------------

    def submit(self, command: Command) -> CommandReply:
        try:
            return self.submit_async(command).result(timeout=REPLY_TIMEOUT_S)
        except FutureTimeout:
            return CommandReply(False, "the robot worker did not answer", Refusal.UNAVAILABLE)

    def submit_async(self, command: Command) -> Future[CommandReply]:
        """Send `command` and return at once: the reply comes in the future. Never blocks the caller (the web
        server's event loop calls this): a robot process that is not answering gets only e-stops, sent from a
        thread of their own, and everything else is refused."""
        future: Future[CommandReply] = Future()
        if not self._alive:
            future.set_result(CommandReply(False, "the robot worker is not running", Refusal.UNAVAILABLE))
            return future
        silent = self.silent_for_s()
        if silent and not isinstance(command, EStop):
            future.set_result(
                CommandReply(False, f"the robot process is not answering ({silent:.1f} s)", Refusal.UNAVAILABLE)
            )
            return future
        request_id = next(self._ids)
        with self._pending_lock:
            self._pending[request_id] = future
        future.add_done_callback(lambda _: self._forget(request_id))
        if silent:  # the pipe may be full: a blocked send must not hold the caller
            threading.Thread(target=self._send_command, args=(request_id, command), daemon=True).start()
        else:
            self._send_command(request_id, command)
        return future

    def _send_command(self, request_id: int, command: Command) -> None:
        try:
            with self._send_lock:
                self._conn.send(("cmd", request_id, command))  # type: ignore[union-attr]
        except OSError:
            self._answer(request_id, CommandReply(False, "the robot worker did not answer", Refusal.UNAVAILABLE))

    def _answer(self, request_id: int, reply: CommandReply) -> None:
        with self._pending_lock:
            future = self._pending.get(request_id)
        if future is not None and not future.done():
            future.set_result(reply)

    def _forget(self, request_id: int) -> None:
        with self._pending_lock:
            self._pending.pop(request_id, None)

    def state(self) -> RobotState:
        return self._board.latest()

    def subscribe(self) -> Subscription:
        return self._bus.subscribe()

    def recent_events(self) -> list[Event]:
        return self._bus.history()

    def describe(self) -> RobotDescription:
        assert self._description is not None, "start() first"
        return self._description

    def sensor_feed(self) -> SensorFeed:
        return self._feed

    def telemetry_since(self, seq: int) -> TelemetryBatch | None:
        return self._telemetry.since(seq)

    def diagnostics(self) -> DiagnosticArray | None:
        return self._diagnostics

    def wait_for(self, predicate: Callable[[RobotState], bool], timeout_s: float) -> bool:
        return self._board.wait_for(predicate, timeout_s)

    # internals -------------------------------------------------------------------------------------------------

    def add_tap(self, tap: Callable[[str, bytes], None]) -> None:
        """`tap(kind, raw)` gets every state and sensor-feed message ("state" or "feed") as it came from the robot
        process, still pickled (another process, the 3D mirror's, reads them without this one encoding them again,
        and decodes only the states it draws). Called on the reader thread: it must not block."""
        self._taps.append(tap)

    def _read(self) -> None:
        assert self._conn is not None
        while True:
            try:
                raw = self._conn.recv_bytes()
            except (EOFError, OSError):
                break
            self._last_heard = time.monotonic()
            message = pickle.loads(raw)
            kind = message[0]
            if kind in ("state", "feed"):
                for tap in self._taps:
                    tap(kind, raw)
            if kind == "state":
                self._board.publish(message[1])
            elif kind == "event":  # numbered here: a restarted robot numbers from 1 again
                self._bus.forward(message[1], renumber=True)
            elif kind == "telemetry":
                self._telemetry.extend(message[1])
            elif kind == "diagnostics":
                self._diagnostics = message[1]
            elif kind == "feed":
                self._feed = merge_feed(self._feed, message[1])
            elif kind == "reply":
                self._answer(message[1], message[2])
        self._alive = False
        with self._pending_lock:
            pending = list(self._pending.values())
        for future in pending:
            if not future.done():
                future.set_result(CommandReply(False, "the robot worker exited", Refusal.UNAVAILABLE))


def merge_feed(current: SensorFeed, changed: SensorFeed) -> SensorFeed:
    """A feed message carries only the sensors that have something new."""
    return SensorFeed(
        camera=changed.camera or current.camera, scan=changed.scan or current.scan, map=changed.map or current.map
    )


# ---------------------------------------------------------------------------------------------------------------
# child process


def _latch_before_ready(worker: Any, latched: EStop, timeout_s: float = 10.0) -> None:
    """Latch the e-stop and wait until the published state shows it: the state sent with "ready" is what the
    server shows first, and it must not show a restarted robot as free to move."""
    worker.submit(latched)
    deadline = time.monotonic() + timeout_s
    while not worker.state().estop_latched:
        if time.monotonic() > deadline:
            raise RuntimeError("the e-stop did not latch on the restarted robot")
        time.sleep(0.005)


def child_main(
    conn: Connection,
    seed: int,
    control_hz: float,
    realtime: bool,
    perception: bool = True,
    planning: PlannerConfig | None = None,
    max_auto_replans: int = 2,
    approve_plans: bool = False,
    voice: VoiceConfig | None = None,
    diagnostics: Thresholds | None = None,
    disk_path: str = ".",
    hardware: HardwareSpec | None = None,
    latched: EStop | None = None,
) -> None:
    """Entry point of the worker process: build the robot, then serve commands until told to stop. `latched`: an
    e-stop to latch before the robot says it is ready (a restart after a crash)."""
    try:
        from robot.model.world import generate_world

        if hardware is not None:
            from robot.hardware.worker import HardwareWorker

            worker: Any = HardwareWorker(
                hardware.config,
                generate_world(seed),
                diagnostics=diagnostics,
                disk_path=disk_path,
                deadman_s=hardware.deadman_s,
                walk=True,  # when the config names an IMU and foot sensors
            )
        else:
            from robot.worker import RobotWorker

            worker = RobotWorker(
                generate_world(seed),
                realtime=realtime,
                control_hz=control_hz,
                perception=perception,
                planning=planning,
                max_auto_replans=max_auto_replans,
                approve_plans=approve_plans,
                voice=voice,
                diagnostics=diagnostics,
                disk_path=disk_path,
            )
        subscription = worker.subscribe()
        if realtime:  # every thread started from here on inherits it; the control loop goes higher still
            raise_thread_priority(WORKER_FIFO_PRIORITY)
        worker.start()
        if latched is not None:
            _latch_before_ready(worker, latched)
        description = worker.describe()  # after starting: it says which microphone and speaker were found
    except Exception as exc:
        # the operator's own mistakes (a servo not answering, a bad robot.toml) are said plainly, without a trace
        plain = type(exc).__name__ in ("BusError", "ConfigError")
        conn.send(("fatal", f"{exc}" if plain else traceback.format_exc()))
        return
    send_lock = threading.Lock()

    def send(message: tuple) -> None:
        with send_lock:
            conn.send(message)

    # Built at start-up and kept (the model, the scene, the planners): set aside from the garbage collector, whose
    # full collections would otherwise scan it all with the control loop stopped.
    gc.collect()
    gc.freeze()
    send(("ready", description, worker.state()))
    stop = threading.Event()
    outbox = threading.Thread(target=_forward_state_and_events, args=(worker, subscription, send, stop), daemon=True)
    outbox.start()
    slow_commands = ThreadPoolExecutor(max_workers=2, thread_name_prefix="robot-commands")

    def handle(request_id: int, command: Command) -> None:
        try:
            reply = worker.submit(command)
        except Exception as exc:  # a bug must answer, not hang the caller
            reply = CommandReply(False, f"internal error: {exc!r}", Refusal.INVALID)
        send(("reply", request_id, reply))

    try:
        while True:
            try:
                message = conn.recv()
            except (EOFError, OSError):  # the parent is gone: stop the robot safely (stop() waits out a real
                worker.submit(EStop(source="parent-lost", reason="the web server is gone"))  # robot's crouch)
                break
            if message[0] == "stop":
                break
            _, request_id, command = message
            if isinstance(command, _IMMEDIATE):
                handle(request_id, command)
            else:
                slow_commands.submit(handle, request_id, command)
    finally:
        stop.set()
        worker.stop()
        slow_commands.shutdown(wait=False, cancel_futures=True)
        outbox.join(timeout=2)
        conn.close()


def _forward_state_and_events(worker: Any, subscription: Subscription, send_raw: Any, stop: threading.Event) -> None:
    last_sent = time.monotonic()

    def send(message: tuple) -> None:
        nonlocal last_sent
        send_raw(message)
        last_sent = time.monotonic()

    last_state = None
    last_feed = SensorFeed()
    last_diagnostics = None
    telemetry_seq = 0
    while not stop.is_set():
        event = subscription.get(timeout=STATE_PERIOD_S)
        try:
            if time.monotonic() - last_sent > BEAT_PERIOD_S:
                send(("beat",))  # nothing changed for a while: still here
            while event is not None:
                send(("event", event))
                event = subscription.get(timeout=0)
            telemetry = worker.telemetry_since(telemetry_seq)
            if telemetry is not None:
                send(("telemetry", telemetry))
                telemetry_seq = telemetry.next_seq
            diagnostics = worker.diagnostics()
            if diagnostics is not last_diagnostics:
                send(("diagnostics", diagnostics))
                last_diagnostics = diagnostics
            state = worker.state()
            if state is not last_state:
                send(("state", state))
                last_state = state
            feed = worker.sensor_feed()
            if feed is not last_feed:  # images and maps cross only when new, and only the new parts
                send(
                    (
                        "feed",
                        SensorFeed(
                            *(
                                new if new is not old else None
                                for new, old in (
                                    (feed.camera, last_feed.camera),
                                    (feed.scan, last_feed.scan),
                                    (feed.map, last_feed.map),
                                )
                            )
                        ),
                    )
                )
                last_feed = feed
        except (OSError, BrokenPipeError):
            return
