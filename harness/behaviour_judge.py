"""What the simulator says happened while a behaviour ran: which robot parts touched what (a collision is any
contact of a robot geom with the walls, the furniture, the obstacles or the objects, other than the feet on the
floor or the dock's mat, and the hand with what it holds), which points the robot came to, and whether an object is
in the hand. Shared by `humanoid bench behaviours` and the tests."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

REACHED_M = 0.25  # within this of a waypoint (its open-floor point), the robot was there
AWAY_M = 0.6  # ... and once this far from it again, a later pass is a new visit
# A contact is counted only where the two geoms are this close (m) in the pose read beside it: the contact list is
# read while the control thread steps the simulation, and a read torn by a step can pair any two geoms (a bench
# run "saw" the trunk on the floor of a robot standing upright, and an ankle on a mug on the counter).
CONFIRM_M = 0.01
FOOT_BODIES = ("l_ank_roll_link", "r_ank_roll_link")
GROUND_GEOMS = ("floor", "charging_dock")


@dataclass
class Judge:
    """Watches the simulation while a behaviour runs: contacts, visits to points."""

    backend: Any
    points: dict[str, tuple[float, float]] = field(default_factory=dict)
    visits: dict[str, int] = field(default_factory=dict)
    near: dict[str, bool] = field(default_factory=dict)
    collisions: list[dict[str, Any]] = field(default_factory=list)  # what touched what, first at (sim s)

    def __post_init__(self) -> None:
        import mujoco

        model = self.backend.model
        roots = model.body_rootid
        robot_root = int(roots[model.body("body_link").id])
        self._robot = {g for g in range(model.ngeom) if int(roots[model.geom_bodyid[g]]) == robot_root}
        feet = {model.body(name).id for name in FOOT_BODIES}
        self._feet = {g for g in self._robot if int(model.geom_bodyid[g]) in feet}
        self._ground = {mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, n) for n in GROUND_GEOMS}
        self._pose = mujoco.MjData(model)  # the judge's own copy of the pose, to measure a contact's geoms in

    def watch(self, state: Any) -> None:
        self._contacts(state.held_object, state.sim_time_s)
        x, y = state.base_position[:2]
        for name, point in self.points.items():
            distance = math.dist((x, y), point)
            if distance < REACHED_M and not self.near.get(name, False):
                self.near[name] = True
                self.visits[name] = self.visits.get(name, 0) + 1
            elif distance > AWAY_M:
                self.near[name] = False

    def in_hand(self, body_name: str) -> bool:
        """The body touches the robot and nothing else: held off the floor and the furniture."""
        model, data = self.backend.model, self.backend.data
        body = model.body(body_name).id
        robot = other = False
        for a, b in _contact_pairs(data):
            for mine, theirs in ((a, b), (b, a)):
                if int(model.geom_bodyid[mine]) == body:
                    robot |= theirs in self._robot
                    other |= theirs not in self._robot
        return robot and not other

    def _contacts(self, held: str | None, sim_time_s: float) -> None:
        """The contacts now (read beside the control thread stepping the simulation: a copy, taken whole or not)."""
        model, data = self.backend.model, self.backend.data
        for a, b in _contact_pairs(data):
            if (a in self._robot) == (b in self._robot):
                continue  # the robot with itself, or the world with itself
            mine, other = (a, b) if a in self._robot else (b, a)
            if mine in self._feet and other in self._ground:
                continue
            body = model.body(int(model.body_rootid[model.geom_bodyid[other]])).name
            if held is not None and body == "obj_" + held.replace(" ", "_"):
                continue
            what = model.geom(int(other)).name or body
            touched = f"{model.body(int(model.geom_bodyid[mine])).name} with {what}"
            if not any(c["what"] == touched for c in self.collisions) and self._touching(mine, other):
                self.collisions.append({"what": touched, "sim_s": round(sim_time_s, 2)})

    def _touching(self, a: int, b: int) -> bool:
        """Whether geoms `a` and `b` are within CONFIRM_M of each other in the simulation's pose now."""
        import mujoco

        model, data, pose = self.backend.model, self.backend.data, self._pose
        pose.qpos[:] = data.qpos
        pose.mocap_pos[:] = data.mocap_pos
        pose.mocap_quat[:] = data.mocap_quat
        mujoco.mj_kinematics(model, pose)
        return mujoco.mj_geomDistance(model, pose, a, b, 2 * CONFIRM_M, None) <= CONFIRM_M


def _contact_pairs(data: Any) -> np.ndarray:
    """The geom pairs in contact now, read beside the control thread stepping the simulation: a copy, taken whole
    (a read torn by a step is taken again)."""
    for _ in range(10):
        try:
            return np.array(data.contact.geom, dtype=int).reshape(-1, 2)
        except (IndexError, ValueError):
            continue
    return np.zeros((0, 2), dtype=int)


def run_judged(behaviour: str, params: dict[str, Any], seed: int, timeout_s: float = 900.0) -> tuple[Any, Judge]:
    """Behaviour `behaviour` on a fresh simulation of world `seed` (not in real time), watched by a judge: its final
    status (None when it did not start) and the judge."""
    from robot.interface import StartBehaviour
    from robot.model.world import generate_world
    from robot.sim.backend import MujocoSimBackend
    from robot.worker import RobotWorker

    layout = generate_world(seed)
    backend = MujocoSimBackend(layout)
    worker = RobotWorker(layout, backend=backend, realtime=False)
    judge = Judge(backend)
    worker.start()
    try:
        worker.wait_for(lambda s: s.sim_time_s >= 0.5, timeout_s)  # standing settled
        reply = worker.submit(StartBehaviour(behaviour, params, source="test"))
        if not reply.accepted:
            return None, judge

        def over(state: Any) -> bool:
            judge.watch(state)
            status = state.behaviour
            return status is not None and status.state.finished and status.command_id == reply.command_id

        worker.wait_for(over, timeout_s)
        return worker.state().behaviour, judge
    finally:
        worker.stop()
