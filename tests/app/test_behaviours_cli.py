"""`humanoid behaviours list` and `run`, in a subprocess as a user runs them (listing and refusing: in this process)."""

from __future__ import annotations

import json
import sqlite3

from tests.app.test_cli import here, humanoid

RUN_KEYS = {"success", "fell", "sim_time_s", "wall_time_s", "feedback", "session_id"}


def test_list_names_every_behaviour_with_its_typed_parameters(tmp_path) -> None:
    done = here(tmp_path, "behaviours", "list", "--json")
    assert done.returncode == 0, done.stderr
    listed = {b["name"]: b for b in json.loads(done.stdout)["behaviours"]}
    assert {"fetch", "tour", "patrol", "demo"} <= listed.keys()
    laps = next(p for p in listed["patrol"]["params"] if p["name"] == "laps")
    expected = {"name": "laps", "kind": "int", "default": 2, "minimum": 0, "maximum": 100, "choices": None}
    assert {key: laps[key] for key in expected} == expected and laps["doc"]
    assert listed["fetch"]["description"] and listed["tour"]["states"][0] == "planning"


def test_run_refuses_a_bad_parameter_naming_it(tmp_path) -> None:
    done = here(tmp_path, "behaviours", "run", "patrol", "--set", "laps=-1", "--json")
    assert done.returncode == 2
    result = json.loads(done.stdout)
    assert result["success"] is False and result["errors"][0].startswith("laps:")
    assert here(tmp_path, "behaviours", "run", "patrol", "--set", "laps").returncode == 2


def test_run_a_tour_headless_and_keep_it_with_the_session(tmp_path) -> None:
    done = humanoid(
        tmp_path, "behaviours", "run", "tour", "--seed", "2", "--set", "places=dock", "--json", timeout_s=600.0
    )
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout)
    assert result.keys() >= RUN_KEYS
    assert result["success"] is True and result["fell"] is False and result["state"] == "succeeded"
    assert result["params"] == {"places": ["charging dock"]}
    assert any(line.startswith("at the charging dock: This is the charging dock") for line in result["feedback"])
    with sqlite3.connect(tmp_path / "cli.db") as db:
        name, state, feedback = db.execute("select name, state, feedback from behaviour_runs").fetchone()
    assert (name, state) == ("tour", "succeeded") and json.loads(feedback) == result["feedback"]
