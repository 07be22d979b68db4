"""Scene: a task's compiled MuJoCo world plus the lookups every layer above needs.

``build_scene(task)`` assembles the MjSpec (``mgdata.sim.world``), compiles it, rejects overlapping initial
poses, lets the objects settle, and remembers that settled state as the task's initial state; ``reset()``
returns to it exactly (robot at ``HOME_Q`` with the gripper open, objects resting at their placements,
articulations at their initial fractions, ``data.time == 0``).

Example::

    scene = build_scene(task)
    scene.reset()
    pos, rot = scene.tcp_pose()
    s = scene.snapshot(); ...; scene.restore(s)
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from types import MappingProxyType

import mujoco
import numpy as np

from mgdata.errors import SceneError
from mgdata.sim import robot
from mgdata.sim.assets import ObjectModel
from mgdata.sim.config import SimConfig, load_sim_config
from mgdata.sim.particles import WIPER_CATEGORY, DustField, LiquidSet, dust_host
from mgdata.sim.physics_config import Physics
from mgdata.sim.taskspec import TaskSpec
from mgdata.sim.world import FLOOR_Z, assemble_spec

PENETRATION_TOL = 0.002
"""Initial poses may touch but not interpenetrate by more than this (m)."""
STATE_SPEC = mujoco.mjtState.mjSTATE_INTEGRATION
OWNER_FLOOR, OWNER_TABLE, OWNER_ROBOT = 0, 1, 2
"""Indices of the fixed owners in ``Scene.owners``; objects follow in task order."""


class Scene:
    """A built task. Construct with :func:`build_scene`.

    Attributes:
        model, data: the MuJoCo model and its data.
        task: the TaskSpec it was built from.
        sim: the Layer 1 settings it was built with (``recipes/sim.toml``).
        physics: timestep and control period (``sim.physics``).
        gripper: the gripper's commands and finger contact model (``sim.gripper``).
        objects: instance name -> ObjectModel, in task order.
        object_names: instance names in task order.
        owners: ``("floor", "table", "robot", *object_names)``; ``geom_owner`` indexes it (−1: no owner).
        geom_owner: int array (ngeom,) giving each colliding geom's owner.
        robot_geom_ids: the robot's colliding geoms.
        floor_z: height of the floor (m); the table top is at z = 0.
        dust: the dust specks, their hosts and their wipers (empty if the task has no dust).
        dust_hosts: dust instance -> the instance it lies on (None: the table).
        liquids: liquid instance name -> its spheres.
    """

    def __init__(self, task: TaskSpec, model: mujoco.MjModel, objects: Mapping[str, ObjectModel],
                 sim: SimConfig) -> None:
        self.task = task
        self.model = model
        self.data = mujoco.MjData(model)
        self.sim = sim
        self.physics: Physics = sim.physics
        self.gripper = sim.gripper
        self.objects: Mapping[str, ObjectModel] = MappingProxyType(dict(objects))
        self.object_names: tuple[str, ...] = tuple(objects)
        self.owners: tuple[str, ...] = ("floor", "table", "robot", *self.object_names)
        self.floor_z = FLOOR_Z
        self.robot_geom_ids = robot.robot_geom_ids(model)
        self._arm_q = robot.arm_qpos_adr(model)
        self._finger_q = robot.finger_qpos_adr(model)
        self._tcp = model.site(robot.TCP_SITE).id
        self._bodies = {n: model.body(n).id for n in self.object_names}
        self.geom_owner = self._owners_of_geoms()
        self._geoms = {n: np.flatnonzero(self.geom_owner == OWNER_ROBOT + 1 + i).astype(np.int32)
                       for i, n in enumerate(self.object_names)}
        self._art = {n: (m.articulation, model.jnt_qposadr[model.joint(f"{n}/{m.articulation.joint}").id])
                     for n, m in objects.items() if m.articulation is not None}
        self.liquids = {n: LiquidSet(model, n, m.particles.count) for n, m in objects.items()
                        if m.particles is not None and m.particles.kind == "liquid"}
        wipers = [self._geoms[n] for n, m in objects.items() if m.category == WIPER_CATEGORY]
        dust = {n: m.particles.count for n, m in objects.items()
                if m.particles is not None and m.particles.kind == "dust"}
        self.dust_hosts = {n: dust_host(task, objects, n) for n in dust}
        """Dust instance -> the instance it lies on (None: the table)."""
        self.dust = DustField(model, dust, np.concatenate(wipers) if wipers else np.zeros(0, dtype=np.int32),
                              {n: self._host(h) for n, h in self.dust_hosts.items()})
        self._initial = self._settled_initial_state()

    # -- construction ------------------------------------------------------------------------------------
    def _host(self, name: str | None) -> tuple[int, np.ndarray]:
        """Body id and colliding-geom mask of a dust host (an instance, or the table for None)."""
        if name is None:
            return self.model.body("table").id, self.geom_owner == OWNER_TABLE
        mask = np.zeros(self.model.ngeom, dtype=bool)
        mask[self._geoms[name]] = True
        return self._bodies[name], mask

    def _owners_of_geoms(self) -> np.ndarray:
        m = self.model
        owner = np.full(m.ngeom, -1, dtype=np.int32)
        index = {n: OWNER_ROBOT + 1 + i for i, n in enumerate(self.object_names)}
        robot_bodies = set(robot.robot_body_ids(m).tolist())
        table = m.body("table").id
        for g in range(m.ngeom):
            if m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0:
                continue
            b = int(m.geom_bodyid[g])
            head = m.body(b).name.split("/", 1)[0]
            if b in robot_bodies:
                owner[g] = OWNER_ROBOT
            elif b == table:
                owner[g] = OWNER_TABLE
            elif head in index:
                owner[g] = index[head]
            elif m.geom(g).name == "floor":
                owner[g] = OWNER_FLOOR
        return owner

    def _place(self) -> None:
        m, d = self.model, self.data
        mujoco.mj_resetData(m, d)  # free objects start at their body poses (= placements)
        d.qpos[self._arm_q] = robot.HOME_Q
        d.qpos[self._finger_q] = robot.GRIPPER_MAX_OPENING / 2.0
        d.ctrl[robot.arm_actuator_ids(m)] = [*robot.HOME_Q, self.gripper.ctrl(0.0)]
        for name, (art, adr) in self._art.items():
            d.qpos[adr] = art.value(self.task.articulation.get(name, 0.0))
        mujoco.mj_forward(m, d)

    def _check_overlaps(self) -> None:
        d = self.data
        for c in d.contact[: d.ncon] if d.ncon else []:
            a, b = self.geom_owner[c.geom1], self.geom_owner[c.geom2]
            if a == b or min(a, b) < 0 or max(a, b) <= OWNER_ROBOT or c.dist >= -PENETRATION_TOL:
                continue
            raise SceneError(
                f"task {self.task.family}/{self.task.task_id}: initial poses overlap: "
                f"{self.owners[a]!r} ({self.model.geom(c.geom1).name}) and {self.owners[b]!r} "
                f"({self.model.geom(c.geom2).name}) interpenetrate by {-c.dist * 1000:.1f} mm"
            )

    def _settled_initial_state(self) -> np.ndarray:
        self._place()
        self._check_overlaps()
        for _ in range(round(self.physics.settle_time / self.physics.timestep)):
            mujoco.mj_step(self.model, self.data)
        self.data.time = 0.0
        mujoco.mj_forward(self.model, self.data)
        self.dust.bind(self.data)  # dust keeps its place on the settled host from here on
        return self.snapshot()

    # -- state -------------------------------------------------------------------------------------------
    def reset(self) -> None:
        """Return to the task's settled initial state (bit-identical every time)."""
        self.restore(self._initial)

    def snapshot(self) -> np.ndarray:
        """The full integration state (``mjSTATE_INTEGRATION``: qpos, qvel, act, ctrl, mocap, warmstart …)."""
        state = np.empty(mujoco.mj_stateSize(self.model, STATE_SPEC))
        mujoco.mj_getState(self.model, self.data, state, STATE_SPEC)
        return state

    def restore(self, state: np.ndarray) -> None:
        """Set the state saved by :meth:`snapshot` and recompute positions and contacts."""
        mujoco.mj_setState(self.model, self.data, state, STATE_SPEC)
        mujoco.mj_forward(self.model, self.data)

    def after_control_step(self) -> None:
        """Per-control-step bookkeeping outside MuJoCo's dynamics: dust follows its hosts and is wiped, from
        the positions and contacts of the state just reached (``mj_forward`` first; only with dust)."""
        if self.dust.mocap_ids:
            mujoco.mj_forward(self.model, self.data)
            self.dust.update(self.data)

    # -- lookups -----------------------------------------------------------------------------------------
    def _known(self, name: str) -> None:
        if name not in self._bodies:
            raise SceneError(
                f"no object instance {name!r} in this scene; instances: {', '.join(self.object_names)}"
            )

    def object_model(self, name: str) -> ObjectModel:
        self._known(name)
        return self.objects[name]

    def object_body(self, name: str) -> int:
        """Body id of an instance's root body."""
        self._known(name)
        return self._bodies[name]

    def object_geom_ids(self, name: str) -> np.ndarray:
        """Colliding geoms of an instance (root, links and particles), sorted."""
        self._known(name)
        return self._geoms[name]

    def loose_bodies(self, name: str) -> tuple[str, ...]:
        """The free bodies that move an instance: its root body, or a liquid's particle bodies."""
        self._known(name)
        liquid = self.liquids.get(name)
        if liquid is None:
            return (name,)
        return tuple(self.model.body(int(b)).name for b in liquid.body_ids)

    def object_pose(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """World position (3,) and rotation matrix (3, 3) of an instance's frame (copies)."""
        b = self.object_body(name)
        return self.data.xpos[b].copy(), self.data.xmat[b].reshape(3, 3).copy()

    def articulation_fraction(self, name: str) -> float:
        """Opening of an instance's articulation: 0 closed … 1 fully open."""
        self._known(name)
        if name not in self._art:
            raise SceneError(f"object {name!r} ({self.objects[name].name}) has no articulation")
        art, adr = self._art[name]
        return art.fraction(float(self.data.qpos[adr]))

    def articulation_qpos_adr(self, name: str) -> int:
        """``qpos`` address of an instance's articulation joint."""
        self.articulation_fraction(name)
        return int(self._art[name][1])

    def tcp_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """World position (3,) and rotation matrix (3, 3) of the TCP site (copies)."""
        return self.data.site_xpos[self._tcp].copy(), self.data.site_xmat[self._tcp].reshape(3, 3).copy()

    def arm_q(self) -> np.ndarray:
        """Measured arm joint angles (7,)."""
        return self.data.qpos[self._arm_q].copy()

    def gripper_opening(self) -> float:
        """Distance between the fingers (m): the sum of the two finger joints."""
        return float(self.data.qpos[self._finger_q].sum())


def build_scene(task: TaskSpec, physics: Physics | None = None, *, sim: SimConfig | None = None) -> Scene:
    """Build, check and settle the scene of ``task`` with the settings ``sim`` (default:
    ``recipes/sim.toml``); ``physics``, if given, replaces its physics.

    Raises:
        SceneError: bad instance names, overlapping initial poses, misplaced liquid, bad goal or articulation.
        AssetError: an unknown object model.
        RobotModelError: the Panda MJCF is missing.
        RecipeError: ``recipes/sim.toml`` is invalid.
    """
    sim = sim or load_sim_config()
    if physics is not None:
        sim = dataclasses.replace(sim, physics=physics)
    spec, objects = assemble_spec(task, sim)
    try:
        model = spec.compile()
    except ValueError as exc:
        raise SceneError(f"task {task.family}/{task.task_id}: MuJoCo rejected the scene: {exc}") from exc
    return Scene(task, model, objects, sim)
