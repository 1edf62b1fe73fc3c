"""`humanoid bench behaviours`: the built-in behaviours end to end in physics, one fresh world per seed, judged by
the simulator's truth rather than by what the behaviour says.

- patrol: 2 laps of the default route; once the robot walks its second lap, a box lands on the path ahead of it
  (never near a waypoint, always leaving a way round). Waypoints reached: the robot's true position came within
  `REACHED_M` of each waypoint, once per lap. Collisions: any MuJoCo contact of a robot geom with the walls, the
  furniture, the obstacles or the objects, other than the feet on the floor or the dock's mat, and the hand with
  what it holds.
- tour: the places presented of all the places (a stop counts when the robot stood within `PRESENTED_M` of the
  place's approach as it said its sentence).
- fetch: an object not in the camera's view at the start, brought to where the robot started: held in the hand
  at the end (it touches the robot and nothing else, or its centre is within `HELD_M` of the hand: a bottle
  gripped by its side has its centre 6.4 cm from the hand; an apple in the hand once showed no contact at the
  moment of judging), the robot within `DELIVERED_M` of its start.
- demo: every gesture performed, a typed command answered between them, without a fall.

Bars (issue 37): >= 10 seeds each; patrol >= 95 % of waypoints, 0 falls, 0 collisions; tour >= 90 % complete;
fetch >= 85 %; demo 100 % without a fall.
"""

from __future__ import annotations

import math
import tempfile
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np

from harness.behaviour_judge import Judge

BEHAVIOURS = ("patrol", "tour", "fetch", "demo")
BARS = {"patrol": 0.95, "tour": 0.90, "fetch": 0.85, "demo": 1.0}
PRESENTED_M = 0.35
DELIVERED_M = 0.35
HELD_M = 0.06  # the object's centre this close to the hand: held
DEMO_COMMAND = "what can you do"
TIMEOUT_S = 1800.0


def run_one(behaviour: str, seed: int) -> dict[str, Any]:
    """One behaviour on world `seed`, in a fresh simulation, judged by the simulator."""
    from app.cli.headless_behaviour import run_behaviour
    from app.settings import Settings
    from robot.interface import RunCommand
    from robot.model.world import generate_world
    from robot.sim.backend import MujocoSimBackend
    from robot.worker import RobotWorker

    layout = generate_world(seed)
    backend = MujocoSimBackend(layout)
    worker = RobotWorker(layout, backend=backend, realtime=False)
    judge = Judge(backend)
    params: dict[str, Any] = {}
    blocker = None
    said: list[bool] = [False]
    if behaviour == "patrol":
        from bench.capstone import PathBlocker

        params = {"laps": 2}
        from robot.behaviours.routes import waypoint_near

        judge.points = {p.name: waypoint_near(layout, p.staging) for p in layout.places}  # the patrol's waypoints
        keep = (*judge.points.values(), tuple(layout.robot_start[:2]))
        blocker = PathBlocker(worker, layout, keep_clear=keep, clear_m=0.45)
    elif behaviour == "tour":
        judge.points = {p.name: p.approach[:2] for p in layout.places}
    elif behaviour == "fetch":
        params = {"object": _out_of_view(worker, layout, seed)}
    elif behaviour == "demo":
        params = {"listen_s": 3.0}

    def during(robot: Any, state: Any) -> None:
        judge.watch(state)
        status = state.behaviour
        if blocker is not None and status is not None and any(line.startswith("lap 2") for line in status.feedback):
            blocker.watch(state)
        if behaviour == "demo" and status is not None and status.machine_state == "listening" and not said[0]:
            said[0] = robot.submit(RunCommand(DEMO_COMMAND)).accepted

    with tempfile.TemporaryDirectory() as tmp:
        settings = Settings(database_url=f"sqlite:///{tmp}/bench.db", audio_dir=f"{tmp}/audio", enable_mirror=False)
        result = run_behaviour(behaviour, params, seed, settings, TIMEOUT_S, during=during, worker=worker)
        truth = _truth(behaviour, result, judge, layout, backend, said[0])
    return {
        "behaviour": behaviour,
        "seed": seed,
        "params": result["params"],
        "success": bool(result["success"] and truth["ok"] and not result["fell"]),
        "state": result["state"],
        "reason": result["reason"],
        "fell": result["fell"],
        "collisions": judge.collisions,
        "sim_s": result["sim_time_s"],
        "wall_s": result["wall_time_s"],
        "dropped_box": None if blocker is None else blocker.dropped_at,
        "feedback": result["feedback"],
        **{k: v for k, v in truth.items() if k != "ok"},
    }


def _out_of_view(worker: Any, layout: Any, seed: int) -> str:
    """An object the camera does not see from the start (the robot looks about first, as it stands)."""
    worker.start()
    worker.wait_for(lambda s: s.perception is not None and s.perception.frame_seq >= 3, 120.0)
    seen = {d.label for d in (worker.state().perception.detections if worker.state().perception else ())}
    hidden = [name for name in layout.object_names if name not in seen]
    rng = np.random.default_rng(seed)
    return str(rng.choice(hidden)) if hidden else layout.object_names[0]


def _truth(
    behaviour: str, result: dict[str, Any], judge: Judge, layout: Any, backend: Any, said: bool
) -> dict[str, Any]:
    if behaviour == "patrol":
        laps = int(result["params"].get("laps", 2))
        reached = sum(min(judge.visits.get(name, 0), laps) for name in judge.points)
        total = laps * len(judge.points)
        reported = [line for line in result["feedback"] if line.startswith("a new obstacle") or " moved " in line]
        return {
            "ok": reached == total and not judge.collisions,
            "waypoints_reached": reached,
            "waypoints": total,
            "changes_reported": reported,
        }
    if behaviour == "tour":
        presented = sum(1 for line in result["feedback"] if line.startswith("at the "))
        stood = sum(1 for name in judge.points if judge.visits.get(name, 0) > 0)
        done = min(presented, stood)
        return {"ok": done == len(judge.points), "places_presented": done, "places": len(judge.points)}
    if behaviour == "fetch":
        from robot.model.scene import object_body_name

        obj = result["params"].get("object", "")
        position = np.array(backend.data.body(object_body_name(obj)).xpos, dtype=float)
        hands = (np.array(backend.data.site(site).xpos) for site in ("right_hand", "left_hand"))
        near_hand = min(float(np.linalg.norm(position - hand)) for hand in hands) < HELD_M
        held = judge.in_hand(object_body_name(obj)) or near_hand
        base = np.array(backend.data.qpos[:2], dtype=float)
        home = math.dist(tuple(base), layout.robot_start[:2]) < DELIVERED_M
        return {"ok": held and home, "held_at_end": held, "at_start": home, "object": obj}
    gestures = sum(1 for line in result["feedback"] if line.startswith(("gesture:", "pointed", "greeted")))
    return {"ok": said and result["success"], "gestures": gestures, "command_answered": said}


def run_behaviours_bench(
    seeds: int = 10,
    seed: int = 0,
    behaviours: tuple[str, ...] = BEHAVIOURS,
    jobs: int = 1,
    heldout_seed: int | None = 100,
) -> dict[str, Any]:
    """Every behaviour on `seeds` worlds from `seed` (the development set), and as many from `heldout_seed` (a set
    never tuned on) when given."""
    sets = {"dev": list(range(seed, seed + seeds))}
    if heldout_seed is not None:
        sets["heldout"] = list(range(heldout_seed, heldout_seed + seeds))
    runs: list[dict[str, Any]] = []
    with ProcessPoolExecutor(max(1, jobs), max_tasks_per_child=1) as pool:
        for name, seed_list in sets.items():
            for behaviour in behaviours:
                for run in pool.map(run_one, [behaviour] * len(seed_list), seed_list):
                    runs.append({**run, "set": name})
    summary = {name: _summary([r for r in runs if r["set"] == name], behaviours) for name in sets}
    return {
        "suite": "behaviours",
        "seeds": seeds,
        "sets": {k: v for k, v in sets.items()},
        "summary": summary,
        "runs": runs,
    }


def _summary(runs: list[dict[str, Any]], behaviours: tuple[str, ...]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for behaviour in behaviours:
        mine = [r for r in runs if r["behaviour"] == behaviour]
        if not mine:
            continue
        falls = sum(bool(r["fell"]) for r in mine)
        entry: dict[str, Any] = {
            "runs": len(mine),
            "falls": falls,
            "success_rate": _rate(r["success"] for r in mine),
            "median_sim_s": float(np.median([r["sim_s"] for r in mine])),
        }
        if behaviour == "patrol":
            reached = sum(r["waypoints_reached"] for r in mine) / max(1, sum(r["waypoints"] for r in mine))
            collisions = sum(len(r["collisions"]) > 0 for r in mine)
            entry |= {
                "waypoints_reached": round(reached, 3),
                "runs_with_collisions": collisions,
                "boxes_dropped": sum(r["dropped_box"] is not None for r in mine),
            }
            entry["bar_met"] = reached >= BARS["patrol"] and falls == 0 and collisions == 0
        elif behaviour == "tour":
            complete = sum(r["places_presented"] for r in mine) / max(1, sum(r["places"] for r in mine))
            entry["completion"] = round(complete, 3)
            entry["bar_met"] = complete >= BARS["tour"]
        elif behaviour == "demo":
            entry["without_fall"] = _rate(not r["fell"] and r["success"] for r in mine)
            entry["bar_met"] = entry["without_fall"] >= BARS["demo"]
        else:
            entry["bar_met"] = entry["success_rate"] >= BARS[behaviour]
        entry["bar_met"] = bool(entry["bar_met"] and len(mine) >= 10)
        entry["failures"] = {
            r["seed"]: r["reason"] or "judged failed by the simulator" for r in mine if not r["success"]
        }
        out[behaviour] = entry
    return out


def _rate(values: Any) -> float:
    items = list(values)
    return round(sum(bool(v) for v in items) / len(items), 3) if items else 0.0
