"""Assembling a task's MjSpec: robot, table, floor, lights, objects, goal marker, cameras, physics options
(the tunable ones from ``recipes/sim.toml``, :mod:`mgdata.sim.config`).

World conventions (the contract other layers code against):

* the table is body ``table``; its top surface is at ``TABLE_TOP_Z = 0`` and spans ``TABLE_X`` × ``TABLE_Y``;
  the floor (geom ``floor``) is ``TABLE_HEIGHT`` below it, at ``FLOOR_Z``;
* the robot's root body ``base`` stands on the table at ``task.robot_base`` facing +X rotated by
  ``task.robot_base_yaw``; its element names are as in ``panda.xml``;
* each object instance is a body named by its instance name, free (joint ``<name>/free``) unless its model
  is ``fixed``; all its elements are prefixed ``<name>/``; particle sets: see ``mgdata.sim.particles``;
* the goal region is body ``goal`` with a visual-only green sphere geom and a site, both named ``goal``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import mujoco
import numpy as np

from mgdata.errors import SceneError
from mgdata.sim import robot
from mgdata.sim.appearance import apply_tint
from mgdata.sim.assets import ObjectModel, get_model
from mgdata.sim.cameras import add_cameras, with_overrides
from mgdata.sim.materials import Look, dress_objects, dress_room
from mgdata.sim.particles import add_particles, particle_models
from mgdata.sim.rooms import add_room
from mgdata.sim.taskspec import TaskSpec

if TYPE_CHECKING:
    from mgdata.sim.config import SimConfig  # which imports this module

TABLE_TOP_Z = 0.0
TABLE_HEIGHT = 0.75
FLOOR_Z = TABLE_TOP_Z - TABLE_HEIGHT
TABLE_X = (-0.25, 1.05)
TABLE_Y = (-0.75, 0.75)
TABLE_THICKNESS = 0.04
WORKSPACE_EXTENT = 2.0
"""m, the model's ``stat.extent``: rendering clips at ``vis.map.znear`` (0.01) × this, 2 cm from a camera.
Left
to MuJoCo it spans the walls (11 m), and the wrist camera lost the fingers 4–11 cm in front of it."""
RESERVED_NAMES = frozenset({"table", "floor", "goal", "world", *robot.ROBOT_LINKS, robot.ROOT_BODY})


def yaw_quat(yaw: float) -> list[float]:
    return [float(np.cos(yaw / 2.0)), 0.0, 0.0, float(np.sin(yaw / 2.0))]


def _check_names(task: TaskSpec) -> None:
    seen: set[str] = set()
    for obj in task.objects:
        if obj.name in seen:
            raise SceneError(
                f"task {task.family}/{task.task_id}: object instance name {obj.name!r} is used twice"
            )
        if obj.name in RESERVED_NAMES or not obj.name or "/" in obj.name:
            raise SceneError(
                f"task {task.family}/{task.task_id}: object instance name {obj.name!r} is not allowed "
                f"(no '/', not one of {', '.join(sorted(RESERVED_NAMES))})"
            )
        seen.add(obj.name)
    for name, fraction in task.articulation.items():
        if name not in seen:
            raise SceneError(f"task articulation names {name!r}, which is not an object instance")
        if not 0.0 <= fraction <= 1.0:
            raise SceneError(
                f"articulation fraction of {name!r} is {fraction}; expected 0 (closed) … 1 (open)"
            )


def _add_environment(spec: mujoco.MjSpec, size: int, look: Look) -> None:
    vis = spec.visual
    vis.global_.offwidth = max(640, size)
    vis.global_.offheight = max(480, size)
    vis.quality.offsamples = 0
    vis.quality.shadowsize = 1024
    spec.stat.extent = WORKSPACE_EXTENT  # fixed, so the walls do not push the near plane past the fingers
    spec.add_texture(name="sky", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
                     builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT, rgb1=[0.78, 0.82, 0.86],
                     rgb2=[0.45, 0.50, 0.56], width=64, height=64)
    spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[4.0, 4.0, 0.1],
                            pos=[0.0, 0.0, FLOOR_Z])
    table = spec.worldbody.add_body(name="table")
    cx, cy = (TABLE_X[0] + TABLE_X[1]) / 2.0, (TABLE_Y[0] + TABLE_Y[1]) / 2.0
    hx, hy = (TABLE_X[1] - TABLE_X[0]) / 2.0, (TABLE_Y[1] - TABLE_Y[0]) / 2.0
    table.add_geom(name="table/top", type=mujoco.mjtGeom.mjGEOM_BOX, size=[hx, hy, TABLE_THICKNESS / 2.0],
                   pos=[cx, cy, TABLE_TOP_Z - TABLE_THICKNESS / 2.0], friction=[0.8, 0.005, 0.0001])
    leg_h = (TABLE_HEIGHT - TABLE_THICKNESS) / 2.0
    for i, (sx, sy) in enumerate(((1, 1), (1, -1), (-1, 1), (-1, -1))):
        table.add_geom(name=f"table/leg{i}", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.03, 0.03, leg_h],
                       pos=[cx + sx * (hx - 0.05), cy + sy * (hy - 0.05), FLOOR_Z + leg_h],
                       rgba=[0.45, 0.33, 0.22, 1.0], contype=0, conaffinity=0)
    dress_room(spec, look, FLOOR_Z)


def _add_goal(spec: mujoco.MjSpec, task: TaskSpec) -> None:
    goal = task.goal
    if goal is None:
        return
    if goal.radius <= 0.0:
        raise SceneError(f"goal region radius must be positive, got {goal.radius}")
    body = spec.worldbody.add_body(name=goal.name, pos=list(goal.pos))
    body.add_geom(name=goal.name, type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[goal.radius, 0.0, 0.0],
                  rgba=[0.15, 0.85, 0.25, 0.35], contype=0, conaffinity=0, group=2, mass=0.0)
    body.add_site(name=goal.name, size=[goal.radius, 0.0, 0.0], group=4)


def assemble_spec(task: TaskSpec, sim: SimConfig) -> tuple[mujoco.MjSpec, dict[str, ObjectModel]]:
    """The task's complete MjSpec, with the physics, gripper and cameras of ``sim``, and the model of each
    object instance (in task order).

    Raises:
        SceneError: duplicate or reserved instance names, bad articulation entries, bad goal.
        AssetError: an unknown object model.
    """
    _check_names(task)
    models = {obj.name: get_model(obj.model) for obj in task.objects}
    for name, frac in task.articulation.items():
        if models[name].articulation is None and frac is not None:
            raise SceneError(f"object {name!r} ({models[name].name}) has no articulation to set")
    spec = robot.load_panda_spec(gripper=sim.gripper, far_lod=sim.render.far_lod)
    spec.modelname = f"{task.family}_{task.task_id:04d}_{task.condition}"
    liquid = any(m.particles is not None and m.particles.kind == "liquid" for m in models.values())
    sim.physics.configure(spec, liquid=liquid)
    base = spec.body(robot.ROOT_BODY)
    base.pos = list(task.robot_base)
    base.quat = yaw_quat(task.robot_base_yaw)
    _add_environment(spec, task.image_size, sim.look)
    for obj in task.objects:
        model = models[obj.name]
        if model.particles is not None:
            continue
        body = spec.worldbody.add_body(name=obj.name, pos=list(obj.pos), quat=yaw_quat(obj.yaw))
        if not model.fixed:
            body.add_freejoint(name=f"{obj.name}/free")
        model.add_to(spec, body, prefix=f"{obj.name}/")
        sim.contact.apply(body, model.category)
    add_particles(spec, task, models, particle_models(models))
    for name, tint in task.tint.items():  # the target OOD variant: material only
        apply_tint(spec, name, tint)
    dress_objects(spec, {name: models[name].category for name in models}, sim.look)
    if task.room:  # the environment OOD variant: visual only
        add_room(spec, task.room, FLOOR_Z)
    _add_goal(spec, task)
    add_cameras(spec, task.robot_base, task.robot_base_yaw, robot.HAND_BODY,
                with_overrides(sim.cameras, task.cameras))
    return spec, models
