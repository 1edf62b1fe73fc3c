"""An object squeezed by the gripper stays where the fingers hold it, under the scene's physics settings.

The fetch carries its object for a minute or more. With MuJoCo's soft contacts alone a held apple crept along the
finger pads (0.3 mm/s while walking) until it slid off their tips: the fetch then ended "no longer in my hand".
These tests hold each of the world's objects between two finger pads built as humanoid_v1's (size, friction,
force-limited position drive), with the pads' long side vertical as when the arm carries (gravity along them).
"""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np
import pytest

from robot.manipulation.grasp_plan import grasp_height
from robot.model import humanoid_v1
from robot.model.scene import add_object, object_body_name, set_physics_options
from robot.model.world import WorldObject, generate_world

HAND_Z = 0.5
OBJECTS = {obj.name: obj for obj in generate_world(0).objects}


def _held(obj: WorldObject) -> tuple[mujoco.MjModel, mujoco.MjData]:
    """A hand (moved by the test) with two fingers closing along y on `obj`, its grasp height between the pads."""
    spec = mujoco.MjSpec()
    set_physics_options(spec)
    hand = spec.worldbody.add_body(name="hand", mocap=True, pos=[0, 0, HAND_Z])
    thickness, width, length = humanoid_v1.FINGER_HALF[2], humanoid_v1.FINGER_HALF[0], humanoid_v1.FINGER_HALF[1]
    for name, side in (("a", 1.0), ("b", -1.0)):
        finger = hand.add_body(name=name, pos=[0, side * (obj.radius + thickness + 0.004), 0])
        finger.add_joint(name=name, type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, -side, 0], range=[0, 0.02], damping=2.0)
        finger.add_geom(
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[width, thickness, length],
            mass=humanoid_v1.FINGER_MASS,
            friction=list(humanoid_v1.FINGER_FRICTION),
            condim=4,
        )
        spec.add_actuator(
            target=name,
            trntype=mujoco.mjtTrn.mjTRN_JOINT,
            gainprm=[humanoid_v1.GRIP_KP_N_PER_M] + [0] * 9,
            biasprm=[0, -humanoid_v1.GRIP_KP_N_PER_M] + [0] * 8,
            biastype=mujoco.mjtBias.mjBIAS_AFFINE,
            forcerange=[-humanoid_v1.GRIP_FORCE_N / 2, humanoid_v1.GRIP_FORCE_N / 2],
            forcelimited=mujoco.mjtLimited.mjLIMITED_TRUE,
        )
    add_object(
        spec, dataclasses.replace(obj, position=(0.0, 0.0, HAND_Z - grasp_height(obj.height, obj.round)), yaw=0.0)
    )
    model = spec.compile()
    data = mujoco.MjData(model)
    data.ctrl[:] = 0.02  # closing as far as they go: the drive's force limit is the squeeze
    for _ in range(int(1.0 / model.opt.timestep)):  # close and settle
        mujoco.mj_step(model, data)
    return model, data


def _in_hand(model: mujoco.MjModel, data: mujoco.MjData, obj: WorldObject) -> np.ndarray:
    return data.body(object_body_name(obj.name)).xpos - data.mocap_pos[0]


@pytest.mark.parametrize("name", sorted(OBJECTS))
def test_a_held_object_does_not_creep_out_of_the_fingers_while_held_still(name: str) -> None:
    obj = OBJECTS[name]
    model, data = _held(obj)
    start = _in_hand(model, data, obj)
    for _ in range(int(10.0 / model.opt.timestep)):
        mujoco.mj_step(model, data)
    moved = float(np.linalg.norm(_in_hand(model, data, obj) - start))
    assert moved < 0.001, f"the {name} moved {moved * 1000:.1f} mm in the fingers in 10 s"


@pytest.mark.parametrize("name", sorted(OBJECTS))
def test_a_held_object_stays_between_the_fingers_while_the_hand_is_shaken_as_by_walking(name: str) -> None:
    """For 30 s the hand bobs 1 cm at 2.5 Hz (the gait's step rhythm: 2.5 m/s^2) and sways 1 cm at half that both
    across the fingers and along them."""
    obj = OBJECTS[name]
    model, data = _held(obj)
    start = _in_hand(model, data, obj)
    steps = int(30.0 / model.opt.timestep)
    for i in range(steps + int(1.0 / model.opt.timestep)):
        t = min(i, steps) * model.opt.timestep
        sway = 0.01 * math.sin(math.pi * 2.5 * t)
        data.mocap_pos[0] = [sway, sway, HAND_Z + 0.01 * math.sin(2 * math.pi * 2.5 * t)]
        mujoco.mj_step(model, data)
    moved = float(np.linalg.norm(_in_hand(model, data, obj) - start))
    assert moved < 0.005, f"the {name} moved {moved * 1000:.1f} mm in the fingers"
