"""Longest test files first, so that two test processes finish together.

`make test` runs the files on two processes (`pytest -n 2 --dist loadfile`), each file whole in one of them. By
default pytest-xdist hands out the files with the most tests first, which left the slow files with few tests (a
whole mission from the command line, the voices' speech test) to the end, where one process ran them alone for
minutes while the other had finished. Here the files are ordered by how long they took (`tests/file_durations.json`,
written by `pytest --record-file-durations`), and `make test` keeps that order (`--no-loadscope-reorder`).
"""

from __future__ import annotations

import json
from collections import defaultdict
from pathlib import Path

import pytest

DURATIONS_FILE = Path(__file__).resolve().parents[1] / "file_durations.json"
UNKNOWN_TEST_S = 1.0  # a file not measured yet counts this much per test


def file_of(nodeid: str) -> str:
    return nodeid.split("::", 1)[0]


def load_durations(path: Path = DURATIONS_FILE) -> dict[str, float]:
    """Seconds per test file from the last recording (empty when there is none or it is unreadable)."""
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return {}
    return {str(k): float(v) for k, v in data.items()} if isinstance(data, dict) else {}


def longest_files_first(items: list[pytest.Item], durations: dict[str, float]) -> list[pytest.Item]:
    """`items` grouped by file, the longest file first; within a file their order is kept (some files' tests
    build on each other, e.g. a session page test reading what earlier tests did on the same server)."""
    by_file: dict[str, list[pytest.Item]] = defaultdict(list)
    for item in items:
        by_file[file_of(item.nodeid)].append(item)

    def seconds(name: str) -> float:
        return durations.get(name, UNKNOWN_TEST_S * len(by_file[name]))

    ordered = sorted(by_file, key=lambda name: (-seconds(name), name))
    return [item for name in ordered for item in by_file[name]]


class DurationRecorder:
    """Sums each file's set-up, call and tear-down times over a run and writes them when it ends."""

    def __init__(self, path: Path = DURATIONS_FILE) -> None:
        self.path = path
        self.seconds: dict[str, float] = defaultdict(float)

    def pytest_runtest_logreport(self, report: pytest.TestReport) -> None:
        self.seconds[file_of(report.nodeid)] += report.duration

    def pytest_sessionfinish(self, session: pytest.Session) -> None:
        if hasattr(session.config, "workerinput"):  # under xdist the controller has every file's reports
            return
        rounded = {name: round(s, 1) for name, s in sorted(self.seconds.items())}
        self.path.write_text(json.dumps(rounded, indent=1) + "\n")
