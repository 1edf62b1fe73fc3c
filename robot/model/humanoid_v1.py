"""`humanoid_v1`: the Robotis OP3 plus a wrist servo and a 1-DOF parallel gripper on each arm (24 XM430-W350).

This module is the one source of truth for the robot: `build_robot_spec()` makes the MuJoCo model (MjSpec, from
the packaged OP3: no model files copied) and `placo_mjcf()` derives from that same spec what the whole-body
controller loads, so the simulated robot and the controller's model cannot disagree.

Joint signs follow each joint's axis in the packaged OP3 (left and right limbs are mirrored).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import mujoco

from robot.model import op3

MODEL_NAME = "humanoid_v1"

# The 24 servo-driven joints, in actuator order. The gripper "joint" is the left finger's slide (m); the right
# finger follows it through an equality constraint, as the two fingers of one servo-driven parallel gripper.
ARM_EXTRA_JOINTS: tuple[str, ...] = ("l_wrist", "r_wrist", "l_grip", "r_grip")
JOINT_NAMES: tuple[str, ...] = (*op3.JOINT_NAMES, *ARM_EXTRA_JOINTS)
LEG_JOINTS: tuple[str, ...] = tuple(n for n in op3.JOINT_NAMES if "hip" in n or "knee" in n or "ank" in n)
GRIPPER_JOINTS: tuple[str, ...] = ("l_grip", "r_grip")

TRUNK_BODY = op3.TRUNK_BODY
# Frames the walking controller needs (placo's HumanoidRobot): the trunk and each sole's centre.
TRUNK_FRAME = "trunk"
FOOT_FRAMES = {"left": "left_foot", "right": "right_foot"}
FOOT_BODIES = {"left": "l_ank_roll_link", "right": "r_ank_roll_link"}
HAND_FRAMES = {"left": "left_hand", "right": "right_hand"}  # between the fingertips, on the closing axis

# XM430-W350 at 12 V.
SERVO_STALL_TORQUE_NM = op3.SERVO_STALL_TORQUE_NM
SERVO_NO_LOAD_SPEED_RAD_S = 46.0 * 2.0 * math.pi / 60.0  # 46 rpm
POSITION_KP_NM_PER_RAD = op3.POSITION_KP_NM_PER_RAD

# Sole of the packaged OP3 foot, in the ankle-roll link frame (from its collision boxes).
SOLE_CENTRE_X = 0.024
SOLE_CENTRE_Y_OUTWARD = 0.0125
SOLE_Z = -0.0305
FOOT_LENGTH = 0.127
FOOT_WIDTH = 0.07

# Gripper (shared FINDINGS.md: grasped a 50 g mug with contacts only). Sizes are half extents (m).
# The fingers close along the wrist link's z: in the plane the arm moves in (the OP3's shoulder roll, elbow and the
# wrist share one axis, x), across the forearm. Closing along x, the arm's pitch would set the closing direction:
# vertical whenever the hand is in front of the body.
PALM_HALF = (0.008, 0.034, 0.016)  # x: thickness, y: along the forearm, z: closing axis
PALM_MASS = 0.082
FINGER_HALF = (0.011, 0.022, 0.003)
FINGER_MASS = 0.012
FINGER_TRAVEL = 0.028  # each finger, from closed (0) to open; the gripper opens 56 mm
GRIP_KP_N_PER_M = 1000.0
GRIP_FORCE_N = 10.0
# The gripper's servo turns a lead screw: each newton on the fingers is this much torque at its shaft.
GRIP_SERVO_NM_PER_N = 0.2
FINGER_FRICTION = (1.2, 0.01, 0.0001)
WRIST_MASS = 0.08
# Where the wrist sits on the forearm link (the packaged forearm spans y 0..0.146, centred at x -0.019).
WRIST_POS_Y = 0.125
FOREARM_X = -0.019

# Geom groups: the world is group 0; the robot's own geometry is 1 (gripper), 2 (OP3 meshes) and 3 (OP3 convex
# collision shapes). Sensors that must not see the robot (the lidar) read group 0 only.
WORLD_GEOM_GROUP = 0
GRIPPER_GEOM_GROUP = 1
DETAILED_MESH_GROUP = 2  # ~355k triangles (drawn_meshes.py): the 3D mirror draws them; exports use the convex shapes

# Head RGB-D camera, as an Intel RealSense D435i: 640 x 480, 87 deg horizontal field of view, in the face.
HEAD_CAMERA = "head_rgbd"
HEAD_CAMERA_BODY = "head_tilt_link"
CAMERA_WIDTH = 640
CAMERA_HEIGHT = 480
CAMERA_HFOV_DEG = 87.0
CAMERA_POS = (0.035, 0.0, 0.02)  # in the head-tilt link: forward of the tilt axis, at eye height
# Lidar: a horizontal ring (as one ring of an Ouster OS1-16) from the pelvis, so that its plane (about 0.17 m above
# the floor when standing) crosses every piece of furniture and obstacle in the apartment.
LIDAR_SITE = "lidar"
LIDAR_POS = (0.0, 0.0, -0.10)  # in the trunk (body_link)


@dataclass(frozen=True)
class JointLimit:
    lower: float
    upper: float


def _mirror(limit: tuple[float, float]) -> tuple[float, float]:
    return (-limit[1], -limit[0])


_LEFT_LIMITS: dict[str, tuple[float, float]] = {
    "sho_pitch": (-2.6, 2.6),
    "sho_roll": (-1.0, 1.6),
    "el": (-2.0, 2.0),
    "hip_yaw": (-0.8, 0.8),
    "hip_roll": (-0.6, 0.6),
    "hip_pitch": (-1.9, 0.8),
    "knee": (-0.05, 2.5),
    "ank_pitch": (-1.3, 1.3),
    "ank_roll": (-0.6, 0.6),
    "wrist": (-1.6, 1.6),
}
# Joints whose axis is mirrored on the right side (their right-side range is the left one negated).
_MIRRORED = {"sho_roll", "hip_pitch", "knee"}


def joint_limits() -> dict[str, JointLimit]:
    """Finite limits for every joint (rad, or m for the gripper): the controller and the servos both enforce them."""
    limits = {"head_pan": JointLimit(-1.5, 1.5), "head_tilt": JointLimit(-1.0, 1.0)}
    for key, left in _LEFT_LIMITS.items():
        right = _mirror(left) if key in _MIRRORED else left
        limits[f"l_{key}"] = JointLimit(*left)
        limits[f"r_{key}"] = JointLimit(*right)
    limits["l_grip"] = JointLimit(0.0, FINGER_TRAVEL)
    limits["r_grip"] = JointLimit(0.0, FINGER_TRAVEL)
    return limits


# Knee bend of the standing posture (rad): a slightly crouched stance keeps the knees off their singularity.
STAND_KNEE_BEND = op3.STAND_KNEE_BEND
CROUCH_KNEE_BEND = 1.4


# The arms at rest are held back beside the trunk (left side; the right mirrors it): hanging down (OP3's own stand),
# the hands with their grippers are 0.22 m out from the trunk's centre and 5 cm above the soles, where the navigator's
# berth (0.24 m for the trunk's centre) left them 1-2 cm from what the robot walked past: patrols touched furniture,
# the dropped box and the floor. Held back, they are 0.15 m out at most, 10 cm higher and clear of the legs.
ARMS_AT_REST = {"sho_pitch": 0.6, "sho_roll": 1.1, "el": -0.8}


def stand_posture(knee_bend: float = STAND_KNEE_BEND) -> dict[str, float]:
    """Joint targets of a standing posture: knees bent, hips and ankles share the bend, the arms held back beside
    the trunk (`ARMS_AT_REST`), grippers closed (an open gripper's lower finger hangs 2 cm above the floor, and a
    walking robot's sway dragged it along)."""
    posture = op3.stand_posture(knee_bend)
    for joint, angle in ARMS_AT_REST.items():
        posture[f"l_{joint}"] = angle
        posture[f"r_{joint}"] = -angle
    posture.update({"l_wrist": 0.0, "r_wrist": 0.0, "l_grip": 0.0, "r_grip": 0.0})
    return posture


# Arm joints whose angle is negated from one side to the other for a mirror-image posture (checked by forward
# kinematics: the mirrored posture puts the other hand at the mirror-image point). The grippers open alike.
_ARM_MIRROR_SIGN = {"sho_pitch": -1.0, "sho_roll": -1.0, "el": -1.0, "wrist": -1.0, "grip": 1.0}


def mirror_arm_joints(positions: dict[str, float]) -> dict[str, float]:
    """The same arm posture for the other side: left joints become right ones and the other way round (what the
    right hand's tuned moves become for the left hand). Arm and gripper joints only: anything else is refused."""
    mirrored = {}
    for name, value in positions.items():
        side, _, joint = name.partition("_")
        if side not in ("l", "r") or joint not in _ARM_MIRROR_SIGN:
            raise ValueError(f"not an arm joint: {name!r}")
        mirrored[f"{'r' if side == 'l' else 'l'}_{joint}"] = _ARM_MIRROR_SIGN[joint] * value
    return mirrored


def crouch_posture() -> dict[str, float]:
    return stand_posture(CROUCH_KNEE_BEND)


# ---------------------------------------------------------------------------------------------------------------
# MuJoCo model


def _add_gripper(spec: mujoco.MjSpec, side: str) -> None:
    """Wrist servo and parallel gripper at the end of one forearm."""
    s = side[0]
    out = 1.0 if side == "left" else -1.0  # the forearm extends along +y (left) or -y (right)
    forearm = spec.body(f"{s}_el_link")
    wrist = forearm.add_body(name=f"{s}_wrist_link", pos=[FOREARM_X, out * WRIST_POS_Y, 0.0])
    wrist.add_joint(name=f"{s}_wrist", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[1, 0, 0])
    # The wrist servo (one XM430) and the palm that carries the gripper servo.
    wrist.add_geom(
        name=f"{s}_wrist_servo",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[0.014, 0.012, 0.017],
        pos=[0, out * 0.010, 0],
        mass=WRIST_MASS,
        rgba=[0.2, 0.2, 0.2, 1],
        group=GRIPPER_GEOM_GROUP,
    )
    palm_y = out * (0.022 + PALM_HALF[1])
    wrist.add_geom(
        name=f"{s}_palm",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=list(PALM_HALF),
        pos=[0, palm_y, 0],
        mass=PALM_MASS,
        rgba=[0.25, 0.25, 0.28, 1],
        group=GRIPPER_GEOM_GROUP,
    )
    finger_y = palm_y + out * (PALM_HALF[1] + FINGER_HALF[1] - 0.006)
    for finger, sign in (("a", 1.0), ("b", -1.0)):
        body = wrist.add_body(name=f"{s}_finger_{finger}", pos=[0, finger_y, 0])
        body.add_joint(
            name=f"{s}_grip" if finger == "a" else f"{s}_grip_mimic",
            type=mujoco.mjtJoint.mjJNT_SLIDE,
            axis=[0, 0, sign],
            range=[0, FINGER_TRAVEL],
            limited=mujoco.mjtLimited.mjLIMITED_TRUE,
            damping=2.0,
            armature=0.01,
        )
        body.add_geom(
            name=f"{s}_finger_{finger}_pad",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=list(FINGER_HALF),
            pos=[0, 0, sign * FINGER_HALF[2]],
            mass=FINGER_MASS,
            friction=list(FINGER_FRICTION),
            condim=4,
            rgba=[0.85, 0.45, 0.1, 1],
            group=GRIPPER_GEOM_GROUP,
        )
    wrist.add_site(name=HAND_FRAMES[side], pos=[0, finger_y + out * 0.006, 0])
    spec.add_equality(type=mujoco.mjtEq.mjEQ_JOINT, name1=f"{s}_grip_mimic", name2=f"{s}_grip")


def _add_servo_actuator(spec: mujoco.MjSpec, joint: str) -> None:
    spec.add_actuator(
        name=f"{joint}_act",
        target=joint,
        trntype=mujoco.mjtTrn.mjTRN_JOINT,
        gainprm=[POSITION_KP_NM_PER_RAD] + [0] * 9,
        biasprm=[0, -POSITION_KP_NM_PER_RAD] + [0] * 8,
        biastype=mujoco.mjtBias.mjBIAS_AFFINE,
        ctrlrange=[-math.pi, math.pi],
        forcerange=[-SERVO_STALL_TORQUE_NM, SERVO_STALL_TORQUE_NM],
        forcelimited=mujoco.mjtLimited.mjLIMITED_TRUE,
    )


def _add_grip_actuator(spec: mujoco.MjSpec, joint: str) -> None:
    """The gripper servo, modelled as a stiff position drive on the finger slide, force-limited like the prototype's."""
    spec.add_actuator(
        name=f"{joint}_act",
        target=joint,
        trntype=mujoco.mjtTrn.mjTRN_JOINT,
        gainprm=[GRIP_KP_N_PER_M] + [0] * 9,
        biasprm=[0, -GRIP_KP_N_PER_M] + [0] * 8,
        biastype=mujoco.mjtBias.mjBIAS_AFFINE,
        ctrlrange=[0, FINGER_TRAVEL],
        ctrllimited=mujoco.mjtLimited.mjLIMITED_TRUE,
        forcerange=[-GRIP_FORCE_N / 2, GRIP_FORCE_N / 2],
        forcelimited=mujoco.mjtLimited.mjLIMITED_TRUE,
    )


def _add_sensors(spec: mujoco.MjSpec) -> None:
    """IMU in the trunk; four force-sensing pads under each sole (their sum and centre give the foot's CoP)."""
    trunk = spec.body(TRUNK_BODY)
    trunk.add_site(name="imu", pos=[0, 0, 0])
    spec.add_sensor(name="imu_gyro", type=mujoco.mjtSensor.mjSENS_GYRO, objtype=mujoco.mjtObj.mjOBJ_SITE, objname="imu")
    spec.add_sensor(
        name="imu_accel", type=mujoco.mjtSensor.mjSENS_ACCELEROMETER, objtype=mujoco.mjtObj.mjOBJ_SITE, objname="imu"
    )
    spec.add_sensor(
        name="imu_quat", type=mujoco.mjtSensor.mjSENS_FRAMEQUAT, objtype=mujoco.mjtObj.mjOBJ_SITE, objname="imu"
    )
    for side, body_name in FOOT_BODIES.items():
        out = 1.0 if side == "left" else -1.0
        foot = spec.body(body_name)
        cy = out * SOLE_CENTRE_Y_OUTWARD
        foot.add_site(name=FOOT_FRAMES[side], pos=[SOLE_CENTRE_X, cy, SOLE_Z])
        for i, (dx, dy) in enumerate(((1, 1), (1, -1), (-1, 1), (-1, -1))):
            name = f"{side}_foot_fsr{i}"
            foot.add_site(
                name=name,
                type=mujoco.mjtGeom.mjGEOM_BOX,
                size=[FOOT_LENGTH / 4, 0.02, 0.008],
                pos=[SOLE_CENTRE_X + dx * FOOT_LENGTH / 4, cy + dy * 0.02, SOLE_Z],
            )
            spec.add_sensor(
                name=name, type=mujoco.mjtSensor.mjSENS_TOUCH, objtype=mujoco.mjtObj.mjOBJ_SITE, objname=name
            )


def _add_perception_sensors(spec: mujoco.MjSpec) -> None:
    """The head camera (MuJoCo cameras look along their -z, y up: this one looks along the head's +x) and the
    lidar's mounting point."""
    vertical_fov = 2.0 * math.degrees(
        math.atan(math.tan(math.radians(CAMERA_HFOV_DEG / 2.0)) * CAMERA_HEIGHT / CAMERA_WIDTH)
    )
    spec.body(HEAD_CAMERA_BODY).add_camera(
        name=HEAD_CAMERA, pos=list(CAMERA_POS), xyaxes=[0, -1, 0, 0, 0, 1], fovy=vertical_fov
    )
    spec.body(TRUNK_BODY).add_site(name=LIDAR_SITE, pos=list(LIDAR_POS), group=4)


def fsr_site_offsets() -> dict[str, list[tuple[float, float]]]:
    """(x, y) of each force pad in its sole frame, in sensor order, for computing the centre of pressure."""
    offsets = [(dx * FOOT_LENGTH / 4, dy * 0.02) for dx, dy in ((1, 1), (1, -1), (-1, 1), (-1, -1))]
    return {"left": offsets, "right": offsets}


def remove_drawn_meshes(spec: mujoco.MjSpec) -> mujoco.MjSpec:
    """`spec` without the detailed meshes, for what never draws the robot (physics, exports): they neither collide
    nor carry mass (every OP3 body states its inertia), so the physics is the same to the bit, and reading and
    compiling their ~355k triangles costs ~0.7 s of a process's start and ~30 MB."""
    for geom in [g for g in spec.geoms if g.group == DETAILED_MESH_GROUP]:
        spec.delete(geom)
    used = {g.meshname for g in spec.geoms}
    for mesh in [m for m in spec.meshes if m.name not in used]:
        spec.delete(mesh)
    return spec


def build_robot_spec() -> mujoco.MjSpec:
    """humanoid_v1 as an MjSpec: servo actuators on every joint with finite limits, grippers, IMU, foot sensors."""
    spec = op3.load_op3_spec()
    spec.modelname = MODEL_NAME
    for side in ("left", "right"):
        _add_gripper(spec, side)
    for name in ("l_wrist", "r_wrist"):
        _add_servo_actuator(spec, name)
    for side in ("l", "r"):  # actuators in JOINT_NAMES order: the OP3's 20, the wrists, then the grippers
        _add_grip_actuator(spec, f"{side}_grip")
    for name, limit in joint_limits().items():
        joint = spec.joint(name)
        joint.range = [limit.lower, limit.upper]
        joint.limited = mujoco.mjtLimited.mjLIMITED_TRUE
    _add_sensors(spec)
    _add_perception_sensors(spec)
    return spec


# ---------------------------------------------------------------------------------------------------------------
# What placo loads

# Frame bodies carry a negligible mass (MJCF requires some on bodies that move).
FRAME_MASS = 1e-6
FRAME_INERTIA = 1e-9


@functools.cache
def placo_mjcf() -> str:
    """The kinematic/inertial model for placo, derived from `build_robot_spec()` (cached: the reach IK asks for it
    again at the first grasp, and deriving it once stood the robot still at the counter for seconds).

    Geometry, actuators, sensors and constraints are dropped (placo needs none of them), the floating base's free
    joint is removed (placo adds its own), and the frames the walking controller expects are added as bodies.
    """
    spec = build_robot_spec()
    spec.modelname = MODEL_NAME + "_placo"
    # The inertias come from a twin: once a spec is compiled, each element deleted from it costs ~80 ms (10 s in
    # all, at every robot start); deleted from a spec never compiled, microseconds.
    compiled = remove_drawn_meshes(build_robot_spec()).compile()
    for body in spec.bodies[1:]:  # freeze the inertias the geometry implied before the geometry goes
        b = compiled.body(body.name)
        body.explicitinertial = True
        body.mass = float(b.mass[0])
        body.ipos = b.ipos.tolist()
        body.iquat = b.iquat.tolist()
        body.inertia = b.inertia.tolist()
    for element in (*spec.sensors, *spec.actuators, *spec.equalities, *spec.cameras):
        spec.delete(element)
    for site in list(spec.sites):
        name = site.name
        if name in FOOT_FRAMES.values() or name in HAND_FRAMES.values():
            parent = site.parent
            parent.add_body(name=name, pos=list(site.pos), mass=FRAME_MASS, inertia=[FRAME_INERTIA] * 3)
        spec.delete(site)
    for element in (*spec.geoms, *spec.meshes, *spec.materials):
        spec.delete(element)
    for joint in list(spec.joints):
        if joint.type == mujoco.mjtJoint.mjJNT_FREE:
            spec.delete(joint)
    spec.body(TRUNK_BODY).add_body(name=TRUNK_FRAME, mass=FRAME_MASS, inertia=[FRAME_INERTIA] * 3)
    # placo measures the trunk-to-hip spacing from this frame, and the head's geometry from the last three.
    spec.body("l_hip_yaw_link").add_body(name="left_hip_yaw", mass=FRAME_MASS, inertia=[FRAME_INERTIA] * 3)
    spec.body("head_pan_link").add_body(name="head_base", mass=FRAME_MASS, inertia=[FRAME_INERTIA] * 3)
    spec.body(HEAD_CAMERA_BODY).add_body(name="head_pitch", mass=FRAME_MASS, inertia=[FRAME_INERTIA] * 3)
    spec.body(HEAD_CAMERA_BODY).add_body(
        name="camera", pos=list(CAMERA_POS), mass=FRAME_MASS, inertia=[FRAME_INERTIA] * 3
    )
    return spec.to_xml()


def servo_torque_per_unit() -> list[float]:
    """Per actuator (JOINT_NAMES order), its force in the torque of the servo behind it: 1 for the revolute joints,
    the lead screw's ratio for the grippers (whose actuators are finger forces in N)."""
    return [GRIP_SERVO_NM_PER_N if name in GRIPPER_JOINTS else 1.0 for name in JOINT_NAMES]
