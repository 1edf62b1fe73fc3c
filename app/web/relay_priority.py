"""The web server's event loop is the e-stop's relay: it runs ahead of ordinary processes, and nothing it starts does.

On two cores shared with a browser (its renderers, its compositor, which Chromium itself raises to nice -8) and the
robot's sensors, an ordinary thread woken by an e-stop waited tens of milliseconds for a core
(`humanoid bench core`: the relay's share of the press-to-stop time was p99 40-60 ms at nice 0 or -10, 16 ms with
real-time scheduling). The loop uses ~10 % of a core, so a low real-time priority costs the rest little; it stays
below the robot's own threads (robot/control/priority.py). `SCHED_RESET_ON_FORK` keeps everything the loop starts
(worker threads, exports, child processes) ordinary: a long export must never run ahead of the browser.
"""

from __future__ import annotations

import os
import threading

RELAY_FIFO_PRIORITY = 20  # above every ordinary process, below the robot's worker (40) and control loop (50)


def raise_relay_priority(fifo_priority: int = RELAY_FIFO_PRIORITY) -> str:
    """Raise the calling thread (the event loop's); returns a sentence saying what it got."""
    tid = threading.get_native_id()
    try:
        policy = os.SCHED_FIFO | os.SCHED_RESET_ON_FORK
        os.sched_setscheduler(tid, policy, os.sched_param(fifo_priority))
        return f"real-time scheduling (SCHED_FIFO {fifo_priority}, not inherited)"
    except (PermissionError, OSError, AttributeError):
        return "normal priority (no permission for real-time scheduling: run as root or grant CAP_SYS_NICE)"


def thread_scheduling(tid: int) -> tuple[int, int]:
    """(policy without the reset-on-fork flag, real-time priority) of thread `tid`: what a test or a check reads."""
    policy = os.sched_getscheduler(tid) & ~getattr(os, "SCHED_RESET_ON_FORK", 0)
    return policy, os.sched_getparam(tid).sched_priority
