"""The suite's files run longest first (so that its two processes end together), from durations a run recorded."""

from __future__ import annotations

import json
from types import SimpleNamespace

from tests.support.file_order import DurationRecorder, load_durations, longest_files_first


def _items(*nodeids: str) -> list:
    return [SimpleNamespace(nodeid=n) for n in nodeids]


def test_files_run_longest_first_and_each_file_keeps_its_own_order() -> None:
    items = _items("a.py::one", "a.py::two", "b.py::one", "c.py::one", "c.py::two", "c.py::three")
    durations = {"a.py": 5.0, "b.py": 90.0}  # c.py not measured yet: 1 s a test
    ordered = [i.nodeid for i in longest_files_first(items, durations)]
    assert ordered == ["b.py::one", "a.py::one", "a.py::two", "c.py::one", "c.py::two", "c.py::three"]


def test_without_a_recording_the_files_with_most_tests_go_first() -> None:
    items = _items("a.py::one", "b.py::one", "b.py::two")
    assert [i.nodeid for i in longest_files_first(items, {})] == ["b.py::one", "b.py::two", "a.py::one"]


def test_a_run_records_each_files_seconds_and_a_bad_recording_is_ignored(tmp_path) -> None:
    path = tmp_path / "durations.json"
    recorder = DurationRecorder(path)
    for nodeid, seconds in (("a.py::one", 1.25), ("a.py::one", 0.5), ("b.py::x", 3.0)):  # set-up and call
        recorder.pytest_runtest_logreport(SimpleNamespace(nodeid=nodeid, duration=seconds))
    recorder.pytest_sessionfinish(SimpleNamespace(config=SimpleNamespace()))
    assert json.loads(path.read_text()) == {"a.py": 1.8, "b.py": 3.0}
    assert load_durations(path) == {"a.py": 1.8, "b.py": 3.0}
    path.write_text("not json")
    assert load_durations(path) == {}
    assert load_durations(tmp_path / "missing.json") == {}


def test_a_test_process_under_xdist_leaves_the_recording_to_the_controller(tmp_path) -> None:
    path = tmp_path / "durations.json"
    recorder = DurationRecorder(path)
    recorder.pytest_runtest_logreport(SimpleNamespace(nodeid="a.py::one", duration=1.0))
    recorder.pytest_sessionfinish(SimpleNamespace(config=SimpleNamespace(workerinput={"workerid": "gw0"})))
    assert not path.exists()
