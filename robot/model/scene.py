"""Builds the MuJoCo model of the OP3 in a seeded apartment with MjSpec (no model files copied)."""

from __future__ import annotations

import functools
import math

import mujoco

from robot.model import humanoid_v1, op3
from robot.model.scene_cache import cached_scene_xml
from robot.model.world import ROOM_X, ROOM_Y, Box, WorldLayout, WorldObject

PHYSICS_TIMESTEP_S = 0.002  # 500 Hz
# Obstacles an operator (or a test) can drop into the apartment while the robot works: kinematic boxes parked far
# outside until placed.
SPARE_OBSTACLES = 2
SPARE_OBSTACLE_HALF = (0.07, 0.07, 0.15)
SPARE_PARKING = (20.0, 20.0)


def spare_obstacle_name(index: int) -> str:
    return f"spare_obstacle_{index}"


# Elliptic cones with impratio 10 stop small objects creeping in a grasp (shared FINDINGS.md).
IMPRATIO = 10.0
# ... but not a sphere held for a minute's walk: the apple crept 0.3 mm/s along the finger pads until it slid off
# their tips (the fetch's "no longer in my hand"). MuJoCo's no-slip pass removes that creep (the apple stayed within
# 1 mm over 60 s) for about 15 % more physics time per step.
NOSLIP_ITERATIONS = 3


def object_body_name(obj_name: str) -> str:
    return "obj_" + obj_name.replace(" ", "_")


def _add_box(parent: mujoco.MjsBody, box: Box) -> None:
    parent.add_geom(
        name=box.name,
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[box.half_x, box.half_y, box.height / 2],
        pos=[box.x, box.y, box.height / 2],
        rgba=list(box.rgba),
    )


def add_object(spec: mujoco.MjSpec, obj: WorldObject) -> None:
    """A free body for a world object (its origin at the object's base centre), shaped as it is."""
    x, y, z = obj.position
    body = spec.worldbody.add_body(
        name=object_body_name(obj.name),
        pos=[x, y, z + 0.001],
        quat=[math.cos(obj.yaw / 2), 0.0, 0.0, math.sin(obj.yaw / 2)],
    )
    body.add_freejoint(name=object_body_name(obj.name) + "_free")
    rgba = list(obj.rgba)
    friction = [1.0, 0.01, 0.0001]
    if obj.shape == "mug":
        body.add_geom(
            type=mujoco.mjtGeom.mjGEOM_CYLINDER,
            size=[obj.radius, obj.height / 2],
            pos=[0, 0, obj.height / 2],
            mass=obj.mass * 0.85,
            rgba=rgba,
            friction=friction,
            condim=4,
        )
        body.add_geom(
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[0.003, 0.006, obj.height * 0.3],
            pos=[obj.radius + 0.006, 0, obj.height / 2],
            mass=obj.mass * 0.15,
            rgba=rgba,
            friction=friction,
            condim=4,
        )  # the handle, along +x
    elif obj.shape == "bottle":
        body.add_geom(
            type=mujoco.mjtGeom.mjGEOM_CYLINDER,
            size=[obj.radius, obj.height * 0.35],
            pos=[0, 0, obj.height * 0.35],
            mass=obj.mass * 0.9,
            rgba=rgba,
            friction=friction,
            condim=4,
        )
        body.add_geom(
            type=mujoco.mjtGeom.mjGEOM_CYLINDER,
            size=[obj.radius * 0.45, obj.height * 0.15],
            pos=[0, 0, obj.height * 0.85],
            mass=obj.mass * 0.1,
            rgba=rgba,
            friction=friction,
            condim=4,
        )
    else:
        body.add_geom(
            type=mujoco.mjtGeom.mjGEOM_SPHERE,
            size=[obj.radius, 0, 0],
            pos=[0, 0, obj.radius],
            mass=obj.mass,
            rgba=rgba,
            friction=friction,
            condim=4,
        )


def set_physics_options(spec: mujoco.MjSpec) -> None:
    """The solver settings the scene's contacts were tuned with: what keeps a grasped object in the hand."""
    spec.option.timestep = PHYSICS_TIMESTEP_S
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.impratio = IMPRATIO
    spec.option.noslip_iterations = NOSLIP_ITERATIONS


def build_scene_spec(layout: WorldLayout, drawn: bool = True) -> mujoco.MjSpec:
    """humanoid_v1 standing at the layout's start pose in its apartment; without the robot's detailed meshes
    unless `drawn` (see `humanoid_v1.remove_drawn_meshes`)."""
    spec = humanoid_v1.build_robot_spec()
    if not drawn:
        humanoid_v1.remove_drawn_meshes(spec)
    spec.modelname = f"{humanoid_v1.MODEL_NAME}_apartment_seed{layout.seed}"
    set_physics_options(spec)

    world = spec.worldbody
    world.add_light(
        pos=[0, 0, 3], dir=[0, 0, -1], type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL, diffuse=[0.6, 0.6, 0.6]
    )
    world.add_geom(
        name="floor",
        type=mujoco.mjtGeom.mjGEOM_PLANE,
        size=[ROOM_X + 0.5, ROOM_Y + 0.5, 0.05],
        rgba=[0.78, 0.74, 0.68, 1.0],
    )
    for box in (*layout.walls, *layout.furniture, *layout.obstacles):
        _add_box(world, box)
    for obj in layout.objects:
        add_object(spec, obj)
    for i in range(SPARE_OBSTACLES):
        body = world.add_body(
            name=spare_obstacle_name(i),
            mocap=True,
            pos=[SPARE_PARKING[0] + i, SPARE_PARKING[1], SPARE_OBSTACLE_HALF[2]],
        )
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=list(SPARE_OBSTACLE_HALF), rgba=[0.8, 0.3, 0.6, 1.0])

    x, y, yaw = layout.robot_start
    trunk = spec.body(op3.TRUNK_BODY)
    trunk.pos = [x, y, op3.STAND_TRUNK_HEIGHT]
    trunk.quat = [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]
    return spec


def build_scene(layout: WorldLayout, drawn: bool = True) -> mujoco.MjModel:
    """The scene compiled: `drawn` for what renders it (cameras, views), not for physics alone."""
    return build_scene_spec(layout, drawn).compile()


@functools.lru_cache(maxsize=4)
def scene_xml(layout: WorldLayout) -> str:
    """The scene as one MJCF string that compiles anywhere on this machine (mesh paths made absolute). Kept, in this
    process and in the user's cache (see scene_cache): writing it compiles the model with the robot's drawn meshes,
    and every session a server opens describes the same robot in the same world."""
    assets = op3.op3_asset_dir()
    packaged = (assets / "op3.xml").stat()  # a reinstalled package writes its files anew

    def write() -> str:
        spec = build_scene_spec(layout)
        spec.meshdir = str(assets / "assets")
        return spec.to_xml()

    recipe = f"{layout!r};{assets};{packaged.st_size};{packaged.st_mtime_ns}"
    return cached_scene_xml(f"seed{layout.seed}", recipe, write)
