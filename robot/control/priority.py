"""Ask the OS to run the calling thread (the control loop) ahead of everything else on the machine.

A fixed-rate loop on a small computer shares its cores with perception, the web server and sometimes a browser;
without priority, the scheduler preempts it for tens of milliseconds. SCHED_FIFO needs root or CAP_SYS_NICE;
without it we fall back to a better nice value, or say plainly that none was granted.
"""

from __future__ import annotations

import os
import threading

CONTROL_FIFO_PRIORITY = 50  # mid-range: above normal threads, at the level of the kernel's IRQ threads
WORKER_FIFO_PRIORITY = 40  # the worker's other threads: below the loop, above every normal process


def raise_thread_priority(fifo_priority: int = CONTROL_FIFO_PRIORITY) -> str:
    """Returns a sentence describing the priority the calling thread got.

    Threads started afterwards by the calling thread inherit it. The worker's other threads need it too: a thread
    holding the interpreter lock that a busy machine preempts stalls the control loop (priority inversion).
    """
    tid = threading.get_native_id()
    try:
        os.sched_setscheduler(tid, os.SCHED_FIFO, os.sched_param(fifo_priority))
        return f"real-time scheduling (SCHED_FIFO {fifo_priority})"
    except (PermissionError, OSError, AttributeError):
        pass
    try:
        os.setpriority(os.PRIO_PROCESS, tid, -10)
        return "raised priority (nice -10); no real-time scheduling"
    except (PermissionError, OSError, AttributeError):
        return "normal priority (no permission for real-time scheduling: run as root or grant CAP_SYS_NICE)"


def ordinary_priority() -> None:
    """For a child process (`subprocess`'s `preexec_fn`): drop the real-time scheduling a worker thread would pass
    on. A recogniser or a speech synthesiser is no real-time work, and on two cores a real-time one would shut the
    web server out while it runs."""
    try:
        os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
        os.setpriority(os.PRIO_PROCESS, 0, 0)
    except (PermissionError, OSError, AttributeError):
        pass
