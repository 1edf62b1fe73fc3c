"""`humanoid serve` runs its event loop, the e-stop's relay, ahead of ordinary processes (a browser's renderers and
compositor, the robot's sensors) on a small machine, and nothing it starts inherits that priority."""

from __future__ import annotations

import os

import psutil
import pytest

from app.web.relay_priority import RELAY_FIFO_PRIORITY, thread_scheduling
from harness.server import ServerProcess

pytestmark = pytest.mark.slow


def test_the_event_loop_runs_at_a_real_time_priority_that_its_threads_and_children_do_not_inherit(tmp_path) -> None:
    with ServerProcess(tmp_path, views=False) as server:
        server.get("/api/config")  # a plain (not async) endpoint: served on a worker thread the loop starts now
        health = server.get("/api/health")
        assert health["mirrors"] == {}  # (HUMANOID_ENABLE_MIRROR=false, as `views=False` sets it, is heeded)
        if os.geteuid() != 0:
            assert "normal priority" in health["relay_priority"]
            pytest.skip("real-time scheduling needs root or CAP_SYS_NICE")
        assert health["relay_priority"].startswith("real-time scheduling")
        process = psutil.Process(server.pid)
        assert thread_scheduling(process.pid) == (os.SCHED_FIFO, RELAY_FIFO_PRIORITY)  # the loop: the main thread
        others = [t.id for t in process.threads() if t.id != process.pid]
        assert others, "the server runs worker threads"
        assert all(thread_scheduling(tid) == (os.SCHED_OTHER, 0) for tid in others)
        for child in process.children(recursive=True):  # the robot raises its own threads, above the relay
            assert thread_scheduling(child.pid)[1] != RELAY_FIFO_PRIORITY, child.cmdline()
